/*
 * assimp_reader.c - meshes through assimp's C API for the `phks` tool and the
 * Python module (assimp_reader.h).
 */
#include "assimp_reader.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#ifdef PHKS_WITH_ASSIMP
#include <assimp/cfileio.h>
#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <limits.h>
#include <pthread.h>
#include <zlib.h>
#endif

static int has_suffix(const char *s, size_t n, const char *suffix)
{
    size_t m = strlen(suffix);
    return n >= m && strncasecmp(s + n - m, suffix, m) == 0;
}

static int is_gzip_name(const char *path)
{
    return has_suffix(path, strlen(path), ".gz");
}

/* A file name's extension is at most this long, with its dot (".md5mesh"
 * is the longest of common[]). */
#define EXTENSION_SIZE 16

/* The extension of the file name with its dot, a final ".gz" left out
 * ("shape.glb.gz" is ".glb"), into ext; 0 when it has none. */
static int scene_extension(const char *path, char ext[EXTENSION_SIZE])
{
    const char *slash = strrchr(path, '/');
    const char *name = slash ? slash + 1 : path;
    size_t n = strlen(name);
    if (is_gzip_name(name))
        n -= 3;
    size_t dot = n;
    while (dot > 1 && name[dot - 1] != '.')
        dot--;
    /* No dot past the first character (".glb" is a hidden file's name),
     * nothing after it, or longer than any extension. */
    if (dot <= 1 || dot == n || n - dot + 2 > EXTENSION_SIZE)
        return 0;
    memcpy(ext, name + dot - 1, n - dot + 1);
    ext[n - dot + 1] = '\0';
    return 1;
}

int assimp_reader_available(void)
{
#ifdef PHKS_WITH_ASSIMP
    return 1;
#else
    return 0;
#endif
}

/* Common formats of assimp: what a directory walk picks up, and what is
 * refused by name without assimp. */
static const char *const common[] = {
    ".gltf", ".glb", ".fbx", ".dae", ".3ds", ".x3d", ".x3db", ".blend",
    ".3mf", ".amf", ".ase", ".ifc", ".lwo", ".lws", ".md2", ".md3",
    ".md5mesh", ".ms3d", ".nff", ".ogex", ".smd", ".ac", ".b3d", ".cob",
    ".dxf", ".irrmesh", ".lxo", ".xgl", ".zgl"};

int assimp_reader_common(const char *path)
{
    char ext[EXTENSION_SIZE];
    if (!scene_extension(path, ext))
        return 0;
    for (size_t i = 0; i < sizeof common / sizeof common[0]; i++)
        if (strcasecmp(ext, common[i]) == 0)
            return 1;
    return 0;
}

int assimp_reader_handles(const char *path)
{
    size_t n = strlen(path);
    if (has_suffix(path, n, ".gz"))
        n -= 3;
    static const char *const own[] = {".off", ".obj", ".ply", ".stl"};
    for (size_t i = 0; i < sizeof own / sizeof own[0]; i++)
        if (has_suffix(path, n, own[i]))
            return 0;
#ifdef PHKS_WITH_ASSIMP
    char ext[EXTENSION_SIZE];
    return scene_extension(path, ext) && aiIsExtensionSupported(ext) == AI_TRUE;
#else
    return assimp_reader_common(path);
#endif
}

#ifdef PHKS_WITH_ASSIMP

/* aiGetErrorString is one buffer for the process. */
static pthread_mutex_t import_lock = PTHREAD_MUTEX_INITIALIZER;

typedef struct gather {
    const struct aiScene *scene;
    const char *object;
    double *xyz;
    uint32_t *tri;
    size_t nv, cap_v, nt, cap_t;
    size_t meshes, matched;
    char *names;   /* the merged meshes' names, "a, b, ..." */
    size_t names_size, names_at;
    int too_large, no_memory;
} gather;

static int grow(void **p, size_t *cap, size_t need, size_t item)
{
    if (need <= *cap)
        return 0;
    size_t cap2 = *cap ? *cap : 64;
    while (cap2 < need)
        cap2 *= 2;
    void *q = realloc(*p, cap2 * item);
    if (!q)
        return -1;
    *p = q;
    *cap = cap2;
    return 0;
}

static void add_name(gather *g, const char *name)
{
    if (!g->names || g->names_at + 1 >= g->names_size)
        return;
    size_t room = g->names_size - g->names_at;
    int w;
    if (g->meshes > 8)
        return;
    if (g->meshes == 8)
        w = snprintf(g->names + g->names_at, room, ", ...");
    else
        w = snprintf(g->names + g->names_at, room, "%s%s",
                     g->meshes > 1 ? ", " : "", *name ? name : "(unnamed)");
    if (w > 0)
        g->names_at += (size_t)w < room ? (size_t)w : room - 1;
}

/* m = a * b, 4 x 4 row-major. */
static void multiply(const double a[16], const double b[16], double m[16])
{
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            double s = 0;
            for (int k = 0; k < 4; k++)
                s += a[4 * i + k] * b[4 * k + j];
            m[4 * i + j] = s;
        }
}

static void add_mesh(gather *g, const struct aiMesh *mesh,
                     const double world[16], const char *name)
{
    size_t faces = 0;
    for (unsigned f = 0; f < mesh->mNumFaces; f++)
        faces += mesh->mFaces[f].mNumIndices == 3;
    if (!faces || !mesh->mNumVertices)
        return;
    if (g->nv + mesh->mNumVertices > UINT32_MAX - 1) {
        g->too_large = 1;
        return;
    }
    if (grow((void **)&g->xyz, &g->cap_v, 3 * (g->nv + mesh->mNumVertices),
             sizeof *g->xyz) != 0 ||
        grow((void **)&g->tri, &g->cap_t, 3 * (g->nt + faces),
             sizeof *g->tri) != 0) {
        g->no_memory = 1;
        return;
    }
    for (unsigned v = 0; v < mesh->mNumVertices; v++) {
        double p[3] = {mesh->mVertices[v].x, mesh->mVertices[v].y,
                       mesh->mVertices[v].z};
        double *out = g->xyz + 3 * (g->nv + v);
        for (int i = 0; i < 3; i++)
            out[i] = world[4 * i] * p[0] + world[4 * i + 1] * p[1] +
                     world[4 * i + 2] * p[2] + world[4 * i + 3];
    }
    for (unsigned f = 0; f < mesh->mNumFaces; f++) {
        const struct aiFace *face = &mesh->mFaces[f];
        if (face->mNumIndices != 3)
            continue;
        for (int i = 0; i < 3; i++)
            g->tri[3 * g->nt + (size_t)i] =
                (uint32_t)(g->nv + face->mIndices[i]);
        g->nt++;
    }
    g->nv += mesh->mNumVertices;
    g->meshes++;
    add_name(g, name);
}

static void walk(gather *g, const struct aiNode *node, const double parent[16],
                 int selected)
{
    const struct aiMatrix4x4 *t = &node->mTransformation;
    const double local[16] = {t->a1, t->a2, t->a3, t->a4, t->b1, t->b2,
                              t->b3, t->b4, t->c1, t->c2, t->c3, t->c4,
                              t->d1, t->d2, t->d3, t->d4};
    double world[16];
    multiply(parent, local, world);
    if (g->object && !selected && strcmp(node->mName.data, g->object) == 0)
        selected = 1;
    for (unsigned i = 0; i < node->mNumMeshes && !g->no_memory; i++) {
        if (node->mMeshes[i] >= g->scene->mNumMeshes)
            continue;
        const struct aiMesh *mesh = g->scene->mMeshes[node->mMeshes[i]];
        int take = !g->object || selected ||
                   strcmp(mesh->mName.data, g->object) == 0;
        if (take) {
            g->matched++;
            add_mesh(g, mesh, world,
                     node->mName.length ? node->mName.data : mesh->mName.data);
        }
    }
    for (unsigned i = 0; i < node->mNumChildren && !g->no_memory; i++)
        walk(g, node->mChildren[i], world, selected);
}

/* The names --object can take, for "it has: ...": each once, since a
 * node and its mesh often share a name, and so do nodes that place the
 * same part. */
typedef struct name_set {
    const char *name[24];
    size_t count;
} name_set;

static void name_set_add(name_set *s, const char *name, size_t limit)
{
    if (!*name || s->count >= limit)
        return;
    for (size_t i = 0; i < s->count; i++)
        if (strcmp(s->name[i], name) == 0)
            return;
    s->name[s->count++] = name;
}

/* The nodes with meshes, the first 12, depth first. */
static void add_node_names(const struct aiNode *node, name_set *s)
{
    if (node->mNumMeshes)
        name_set_add(s, node->mName.data, 12);
    for (unsigned i = 0; i < node->mNumChildren; i++)
        add_node_names(node->mChildren[i], s);
}

/* "no node or mesh named NAME (it has: a, b, ...)" into err. */
static void say_no_object(const struct aiScene *scene, const char *object,
                          char *err, size_t err_size)
{
    name_set s = {{0}, 0};
    char list[400];
    size_t at = 0;
    add_node_names(scene->mRootNode, &s);
    for (unsigned i = 0; i < scene->mNumMeshes; i++)
        name_set_add(&s, scene->mMeshes[i]->mName.data,
                     sizeof s.name / sizeof s.name[0]);
    list[0] = '\0';
    for (size_t i = 0; i < s.count && at + 1 < sizeof list; i++) {
        int w = snprintf(list + at, sizeof list - at, "%s%s", i ? ", " : "",
                         s.name[i]);
        if (w > 0)
            at += (size_t)w < sizeof list - at ? (size_t)w
                                               : sizeof list - at - 1;
    }
    snprintf(err, err_size, "no node or mesh named %s (it has: %s)", object,
             s.count ? list : "no named meshes");
}

/* phks.h's promise for the library's own gzip'd files holds here too: a
 * file inflates to 2 GiB at most. */
#define INFLATED_LIMIT ((size_t)1 << 31)

/* Grows *data (capacity *cap, at most max) so that it holds more bytes
 * than `used` (below max); 0, or -1 when out of memory. */
static int grow_bytes(unsigned char **data, size_t *cap, size_t used,
                      size_t max)
{
    if (used < *cap)
        return 0;
    size_t cap2 = *cap ? 2 * *cap : (size_t)1 << 16;
    if (cap2 > max)
        cap2 = max;
    unsigned char *bigger = realloc(*data, cap2);
    if (!bigger)
        return -1;
    *data = bigger;
    *cap = cap2;
    return 0;
}

/* The file at path into a new buffer (free it, also on failure):
 * inflated when it is gzip'd (every member, as gzip -d does), as it is
 * otherwise (zlib reads such files through). PHKS_OK, or a status and the
 * reason in err. */
static phks_status inflate_file(const char *path, unsigned char **data,
                                size_t *size, char *err, size_t err_size)
{
    size_t cap = 0;
    *data = NULL;
    *size = 0;
    errno = 0;  /* gzopen sets it only when the file cannot be opened */
    gzFile z = gzopen(path, "rb");
    if (!z) {
        snprintf(err, err_size, "%s", errno ? strerror(errno)
                                            : "out of memory");
        return errno ? PHKS_ERROR_IO : PHKS_ERROR_OUT_OF_MEMORY;
    }
    phks_status st = PHKS_OK;
    for (;;) {
        /* One byte past the limit tells a file at it from one above. */
        if (*size > INFLATED_LIMIT) {
            snprintf(err, err_size, "gzip data inflates to more than %zu "
                     "bytes", INFLATED_LIMIT);
            st = PHKS_ERROR_TOO_LARGE;
            break;
        }
        if (grow_bytes(data, &cap, *size, INFLATED_LIMIT + 1) != 0) {
            snprintf(err, err_size, "out of memory inflating the gzip data");
            st = PHKS_ERROR_OUT_OF_MEMORY;
            break;
        }
        size_t room = cap - *size;
        int n = gzread(z, *data + *size, room > INT_MAX ? INT_MAX
                                                        : (unsigned)room);
        if (n < 0) {
            int code = Z_OK;
            const char *why = gzerror(z, &code);
            size_t named = strlen(path);  /* zlib says "PATH: reason" */
            if (strncmp(why, path, named) == 0 && why[named] == ':')
                why += named + (why[named + 1] == ' ' ? 2 : 1);
            snprintf(err, err_size, "gzip data: %s",
                     code == Z_ERRNO ? strerror(errno) : why);
            st = code == Z_ERRNO ? PHKS_ERROR_IO : PHKS_ERROR_PARSE;
            break;
        }
        if (n == 0)
            break;
        *size += (size_t)n;
    }
    /* gzread ends quietly at the end of a file cut inside a member; only
     * gzclose tells. */
    if (gzclose_r(z) == Z_BUF_ERROR && st == PHKS_OK) {
        snprintf(err, err_size, "gzip data: truncated (the file ends "
                                "inside a compressed stream)");
        st = PHKS_ERROR_TRUNCATED;
    }
    return st;
}

/* A compressed scene is read through this file system (assimp's
 * aiFileIO), under its name without ".gz": that name opens the inflated
 * bytes, any other the file itself, read whole (and inflated when it is
 * gzip'd too), so that the files a scene refers to (a glTF's .bin) are
 * found beside it as for an uncompressed one. aiImportFileFromMemory
 * would look for them in the current folder. */
typedef struct inflated_scene {
    const char *name;  /* the path without ".gz" */
    const unsigned char *data;
    size_t size;
} inflated_scene;

typedef struct memory_file {
    const unsigned char *data;
    size_t size, at;
    unsigned char *owned;  /* data, when read for this file */
} memory_file;

static memory_file *memory_of(struct aiFile *file)
{
    return (memory_file *)(void *)file->UserData;
}

static size_t memory_read(struct aiFile *file, char *buffer, size_t size,
                          size_t count)
{
    memory_file *m = memory_of(file);
    size_t left = (m->size - m->at) / (size ? size : 1);
    size_t n = size ? (count < left ? count : left) : 0;
    memcpy(buffer, m->data + m->at, n * size);
    m->at += n * size;
    return n;
}

static size_t memory_write(struct aiFile *file, const char *buffer,
                           size_t size, size_t count)
{
    (void)file, (void)buffer, (void)size, (void)count;
    return 0;
}

static size_t memory_tell(struct aiFile *file)
{
    return memory_of(file)->at;
}

static size_t memory_size(struct aiFile *file)
{
    return memory_of(file)->size;
}

static void memory_flush(struct aiFile *file)
{
    (void)file;
}

/* assimp passes a backward offset as a size_t that wraps around. */
static enum aiReturn memory_seek(struct aiFile *file, size_t offset,
                                 enum aiOrigin origin)
{
    memory_file *m = memory_of(file);
    size_t base = origin == aiOrigin_SET   ? 0
                  : origin == aiOrigin_CUR ? m->at
                                           : m->size;
    size_t to = base + offset;
    if (to > m->size)
        return aiReturn_FAILURE;
    m->at = to;
    return aiReturn_SUCCESS;
}

static struct aiFile *memory_open(struct aiFileIO *io, const char *name,
                                  const char *mode)
{
    const inflated_scene *scene = (const inflated_scene *)(void *)io->UserData;
    struct aiFile *file = calloc(1, sizeof *file);
    memory_file *m = calloc(1, sizeof *m);
    char err[256];
    int ok = file && m && !strpbrk(mode, "wa+");
    if (ok && strcmp(name, scene->name) == 0) {
        m->data = scene->data;
        m->size = scene->size;
    } else if (ok) {
        ok = inflate_file(name, &m->owned, &m->size, err, sizeof err) ==
             PHKS_OK;
        m->data = m->owned;
    }
    if (!ok) {
        if (m)
            free(m->owned);
        free(m);
        free(file);
        return NULL;
    }
    *file = (struct aiFile){memory_read, memory_write, memory_tell,
                            memory_size, memory_seek, memory_flush,
                            (aiUserData)(void *)m};
    return file;
}

static void memory_close(struct aiFileIO *io, struct aiFile *file)
{
    (void)io;
    free(memory_of(file)->owned);
    free(memory_of(file));
    free(file);
}

/* assimp's steps after reading: triangles only, and identical vertices
 * joined (assimp_reader.h, vertex numbering). */
#define IMPORT_STEPS (aiProcess_Triangulate | aiProcess_JoinIdenticalVertices)

/* The gzip'd scene at path, inflated and read under its name without
 * ".gz" (inflated_scene); NULL with a status and the reason in err
 * (assimp's left in aiGetErrorString). Call under import_lock. */
static const struct aiScene *import_compressed(const char *path,
                                               phks_status *st, char *err,
                                               size_t err_size)
{
    size_t n = strlen(path) - 3;
    char *name = malloc(n + 1);
    inflated_scene scene_file = {name, NULL, 0};
    unsigned char *data = NULL;
    if (!name) {
        snprintf(err, err_size, "out of memory");
        *st = PHKS_ERROR_OUT_OF_MEMORY;
        return NULL;
    }
    memcpy(name, path, n);
    name[n] = '\0';
    const struct aiScene *scene = NULL;
    *st = inflate_file(path, &data, &scene_file.size, err, err_size);
    if (*st == PHKS_OK) {
        struct aiFileIO io = {memory_open, memory_close,
                              (aiUserData)(void *)&scene_file};
        scene_file.data = data;
        scene = aiImportFileEx(name, IMPORT_STEPS, &io);
    }
    free(data);
    free(name);
    return scene;
}

/* The scene of the file at path (gzip'd or not), or NULL with a status and
 * the reason in err. */
static const struct aiScene *import_scene(const char *path, phks_status *st,
                                          char *err, size_t err_size)
{
    *st = PHKS_OK;
    pthread_mutex_lock(&import_lock);
    const struct aiScene *scene =
        is_gzip_name(path) ? import_compressed(path, st, err, err_size)
                           : aiImportFile(path, IMPORT_STEPS);
    if (*st == PHKS_OK && (!scene || !scene->mRootNode)) {
        const char *why = aiGetErrorString();
        snprintf(err, err_size, "assimp: %s",
                 why && *why ? why : "no scene in the file");
        if (scene)
            aiReleaseImport(scene);
        scene = NULL;
        *st = PHKS_ERROR_PARSE;
    }
    pthread_mutex_unlock(&import_lock);
    return scene;
}

phks_status assimp_reader_load(const char *path, const char *object,
                            phks_mesh **mesh, char *note, size_t note_size,
                            char *err, size_t err_size)
{
    *mesh = NULL;
    if (note && note_size)
        note[0] = '\0';
    FILE *f = fopen(path, "rb");
    if (!f) {
        snprintf(err, err_size, "%s", strerror(errno));
        return PHKS_ERROR_IO;
    }
    fclose(f);
    phks_status st;
    const struct aiScene *scene = import_scene(path, &st, err, err_size);
    if (!scene)
        return st;

    char names[512];
    names[0] = '\0';
    gather g = {.scene = scene, .object = object, .names = names,
                .names_size = sizeof names};
    static const double identity[16] = {1, 0, 0, 0, 0, 1, 0, 0,
                                        0, 0, 1, 0, 0, 0, 0, 1};
    walk(&g, scene->mRootNode, identity, 0);
    if (g.no_memory) {
        snprintf(err, err_size, "out of memory");
        st = PHKS_ERROR_OUT_OF_MEMORY;
    } else if (g.too_large) {
        snprintf(err, err_size, "more than 2^32 - 2 vertices");
        st = PHKS_ERROR_TOO_LARGE;
    } else if (object && !g.matched) {
        say_no_object(scene, object, err, err_size);
        st = PHKS_ERROR_INVALID_ARGUMENT;
    } else if (!g.nt) {
        snprintf(err, err_size, "no triangles in the scene%s%s",
                 object ? " under " : "", object ? object : "");
        st = PHKS_ERROR_NO_TRIANGLES;
    } else {
        st = phks_mesh_create(g.xyz, g.nv, g.tri, g.nt, mesh);
        if (st != PHKS_OK) {
            const char *why = phks_last_error_message();
            snprintf(err, err_size, "%s",
                     why && *why ? why : phks_status_string(st));
        } else if (!object && g.meshes > 1 && note && note_size)
            snprintf(note, note_size, "%zu meshes (%s) merged into one shape",
                     g.meshes, names);
    }
    free(g.xyz);
    free(g.tri);
    aiReleaseImport(scene);
    return st;
}

#else

phks_status assimp_reader_load(const char *path, const char *object,
                            phks_mesh **mesh, char *note, size_t note_size,
                            char *err, size_t err_size)
{
    (void)object;
    *mesh = NULL;
    if (note && note_size)
        note[0] = '\0';
    char ext[EXTENSION_SIZE];
    snprintf(err, err_size, "built without assimp: cannot read %s",
             scene_extension(path, ext) ? ext : "this format");
    return PHKS_ERROR_UNKNOWN_FORMAT;
}

#endif
