/*
 * cli_bench_item.c - one signature of `phks bench`: load the model, make
 * the version (complete, partial scan or incomplete), take the signature
 * from the cache or compute it, for partial and incomplete queries count
 * the feature points next to the cut, and for the source part trace each
 * feature point of a version back to the source mesh.
 */
#include "bench/cli_bench_parts.h"
#include "assimp_reader.h"
#include "partial.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

const char *const bench_kind_name[KIND_COUNT] = {"complete", "partial",
                                                 "incomplete"};

uint64_t bench_seed(unsigned seed_base, const char *name, int kind)
{
    uint64_t h = cli_mix64(seed_base);
    h = cli_hash_bytes(h, name, strlen(name));
    return cli_mix64(h ^ (uint64_t)kind);
}

/* ---- the cache ----------------------------------------------------------- */
/* The fields that shape the numbers: those of 0.1.0 by name, then every
 * byte from boundary_margin to the end of the struct, which holds the
 * fields carved out of `reserved` since and the rest of `reserved`, so
 * fields added later are covered too. */
static uint64_t hash_options(uint64_t h, const phks_options *o)
{
    h = cli_hash_double(h, o->tau);
    h = cli_hash_double(h, o->cutoff);
    h = cli_hash_u64(h, o->eigen_count);
    h = cli_hash_u64(h, o->feature_count);
    h = cli_hash_u64(h, o->scale_count);
    for (uint32_t i = 0; i < o->scale_count && i < PHKS_MAX_SCALES; i++)
        h = cli_hash_double(h, o->scales[i]);
    h = cli_hash_double(h, o->feature_scale);
    h = cli_hash_u64(h, (uint64_t)(int64_t)o->operator_kind);
    h = cli_hash_u64(h, (uint64_t)(int64_t)o->box);
    size_t tail = offsetof(phks_options, boundary_margin);
    return cli_hash_bytes(h, (const unsigned char *)o + tail,
                          sizeof *o - tail);
}

/* The exact arrays the signature is computed from: a changed file or
 * generator never reuses a stale signature. */
static uint64_t hash_mesh(uint64_t h, const phks_mesh *mesh)
{
    size_t n = phks_mesh_vertex_count(mesh), m = phks_mesh_triangle_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    const uint32_t *tri = phks_mesh_triangles(mesh);
    h = cli_hash_u64(cli_hash_u64(h, n), m);
    for (size_t i = 0; i < 3 * n; i++)
        h = cli_hash_double(h, xyz[i]);
    for (size_t i = 0; i < 3 * m; i++)
        h = cli_hash_u64(h, tri[i]);
    return h;
}

static uint64_t cache_key(const bench_plan *p, const bench_item *it,
                          uint64_t seed, const phks_mesh *mesh)
{
    uint64_t h = cli_hash_string(0, "phks-cli-cache-1");
    h = cli_hash_u64(h, phks_version_number());
    h = cli_hash_string(h, p->models[it->model].row->file);
    h = cli_hash_u64(cli_hash_u64(h, (uint64_t)it->kind), seed);
    return hash_mesh(hash_options(h, &p->options), mesh);
}

/* The file of one output: a feature function's signature (`what` one of
 * BENCH_FEATURES_*), or with `what` BENCH_FEATURES_COUNT the eigenvalue
 * descriptor. HKS keeps the names of the caches written before the
 * other outputs existed. */
static char *cache_path(const bench_plan *p, uint64_t key, int what)
{
    if (what != BENCH_FEATURES_HKS)
        key = cli_hash_string(key, what < BENCH_FEATURES_COUNT
                                       ? bench_feature_name[what] : "evd");
    char *path = malloc(strlen(p->cache_dir) + 32);
    if (path)
        sprintf(path, "%s/%016llx.%s", p->cache_dir, (unsigned long long)key,
                what < BENCH_FEATURES_COUNT ? "sig" : "evd");
    return path;
}

static phks_signature *cache_load(const char *path)
{
    unsigned char *blob;
    size_t size;
    phks_signature *sig = NULL;
    if (!path || cli_read_file(path, &blob, &size) != 0)
        return NULL;
    if (phks_signature_decode(blob, size, &sig) != PHKS_OK)
        sig = NULL;  /* damaged or foreign: computed again and replaced */
    free(blob);
    return sig;
}

/* The descriptor as the doubles in memory: the cache is this machine's. */
static double *cache_load_evd(const char *path)
{
    unsigned char *data;
    size_t size;
    if (!path || cli_read_file(path, &data, &size) != 0)
        return NULL;
    if (size == BENCH_EVD_COUNT * sizeof(double))
        return (double *)data;
    free(data);
    return NULL;
}

static void cache_store_evd(const char *path, const double *evd)
{
    if (path && evd &&
        cli_write_file_atomic(path, evd, BENCH_EVD_COUNT * sizeof *evd) != 0)
        cli_say(stderr, "phks: %s: %s (not cached)\n", path, strerror(errno));
}

static void cache_store(const char *path, const phks_signature *sig)
{
    unsigned char *blob;
    size_t size;
    if (!path || cli_encode(sig, &blob, &size) != PHKS_OK)
        return;
    if (cli_write_file_atomic(path, blob, size) != 0)
        cli_say(stderr, "phks: %s: %s (not cached)\n", path, strerror(errno));
    free(blob);
}

/* ---- features next to the cut ---------------------------------------- */
static int edge_cmp(const void *a, const void *b)
{
    const uint32_t *x = a, *y = b;
    return x[0] != y[0] ? (x[0] > y[0]) - (x[0] < y[0])
                        : (x[1] > y[1]) - (x[1] < y[1]);
}

/* Vertices of mesh (made from pc) on a boundary edge that is not one of
 * src's boundary edges: 1 in the returned array (free it), or NULL. */
static unsigned char *cut_vertices(const phks_mesh *src, const piece *pc,
                                   const phks_mesh *mesh)
{
    size_t n = phks_mesh_vertex_count(mesh);
    size_t nb = phks_mesh_boundary_edge_count(mesh);
    size_t ns = phks_mesh_boundary_edge_count(src);
    const uint32_t *be = phks_mesh_boundary_edges(mesh);
    const uint32_t *sbe = phks_mesh_boundary_edges(src);
    const uint32_t *origin = phks_mesh_vertex_origin(mesh);
    unsigned char *cut = calloc(n ? n : 1, 1);
    for (size_t e = 0; cut && e < nb; e++) {
        uint32_t a = pc->source_vertex[origin[be[2 * e]]];
        uint32_t b = pc->source_vertex[origin[be[2 * e + 1]]];
        uint32_t key[2] = {a < b ? a : b, a < b ? b : a};
        if (!ns || !bsearch(key, sbe, ns, 2 * sizeof *sbe, edge_cmp))
            cut[be[2 * e]] = cut[be[2 * e + 1]] = 1;
    }
    return cut;
}

static double longest_side(const phks_mesh *mesh)
{
    const double *xyz = phks_mesh_vertices(mesh);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, side = 0;
    double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < phks_mesh_vertex_count(mesh); v++)
        for (int c = 0; c < 3; c++) {
            lo[c] = fmin(lo[c], xyz[3 * v + c]);
            hi[c] = fmax(hi[c], xyz[3 * v + c]);
        }
    for (int c = 0; c < 3; c++)
        side = fmax(side, hi[c] - lo[c]);
    return side;
}

static int near_cut(const double p[3], const double *xyz,
                    const unsigned char *cut, size_t n, double r)
{
    for (size_t v = 0; v < n; v++) {
        const double *q = xyz + 3 * v;
        double d2 = (p[0] - q[0]) * (p[0] - q[0]) +
                    (p[1] - q[1]) * (p[1] - q[1]) +
                    (p[2] - q[2]) * (p[2] - q[2]);
        if (cut[v] && d2 <= r * r)
            return 1;
    }
    return 0;
}

/* Feature points, and for comparison all vertices, of the piece within r
 * of a cut vertex. */
static void count_near_cut(const phks_mesh *src, const piece *pc,
                           const phks_mesh *mesh, bench_item *it)
{
    unsigned char *cut = cut_vertices(src, pc, mesh);
    double r = BENCH_CUT_RADIUS * longest_side(src);
    size_t n = phks_mesh_vertex_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    if (!cut)
        return;
    it->features = phks_signature_feature_count(it->sig);
    for (size_t f = 0; f < it->features; f++) {
        double p[3];
        phks_signature_feature_position(it->sig, f, p);
        it->near_cut += (size_t)near_cut(p, xyz, cut, n, r);
    }
    it->vertices = n;
    for (size_t v = 0; v < n; v++)
        it->vertices_near_cut +=
            cut[v] || near_cut(xyz + 3 * v, xyz, cut, n, r);
    free(cut);
}

/* ---- where the features came from ---------------------------------------- */
/* Per feature of sig (made from mesh, made from pc): the vertex of the
 * source mesh it came from. The generator ran on the loaded mesh's own
 * arrays, so source_vertex already numbers the source's vertices as its
 * complete signature does. NULL when out of memory. */
static uint32_t *trace_features(const piece *pc, const phks_mesh *mesh,
                                const phks_signature *sig)
{
    size_t n = phks_signature_feature_count(sig);
    const uint32_t *origin = phks_mesh_vertex_origin(mesh);
    uint32_t *truth = malloc((n ? n : 1) * sizeof *truth);
    for (size_t f = 0; truth && f < n; f++)
        truth[f] = pc->source_vertex[origin[phks_signature_feature_vertex(sig,
                                                                          f)]];
    return truth;
}

/* ---- one item ------------------------------------------------------------ */
static phks_status make_version(const phks_mesh *src, int kind, uint64_t seed,
                                piece *pc, phks_mesh **mesh,
                                const char **reason)
{
    const double *xyz = phks_mesh_vertices(src);
    const uint32_t *tri = phks_mesh_triangles(src);
    size_t n = phks_mesh_vertex_count(src), m = phks_mesh_triangle_count(src);
    int rc = kind == KIND_PARTIAL
                 ? piece_partial_scan(xyz, n, tri, m, seed, pc)
                 : piece_incomplete(xyz, n, tri, m, seed, pc);
    if (rc != 0) {
        *reason = "the generator kept no triangle (or ran out of memory)";
        return PHKS_ERROR_NO_TRIANGLES;
    }
    return phks_mesh_create(pc->xyz, pc->vertex_count, pc->triangles,
                            pc->triangle_count, mesh);
}

phks_status bench_load(const bench_model *model, phks_mesh **mesh,
                       const char **reason)
{
    if (!assimp_reader_handles(model->row->path))
        return phks_mesh_load(model->row->path, mesh);
    static _Thread_local char err[1024];
    phks_status st = assimp_reader_load(model->row->path, NULL, mesh, NULL, 0,
                                     err, sizeof err);
    if (st != PHKS_OK)
        *reason = err;
    return st;
}

/* The item's outputs from the cache, all or none. */
static void from_cache(const bench_plan *p, bench_item *it, uint64_t key)
{
    char *sig = cache_path(p, key, p->features);
    char *evd = p->evd ? cache_path(p, key, BENCH_FEATURES_COUNT) : NULL;
    it->sig = cache_load(sig);
    it->evd = cache_load_evd(evd);
    it->cached = it->sig && (!p->evd || it->evd);
    if (!it->cached) {
        phks_signature_free(it->sig);
        free(it->evd);
        it->sig = NULL;
        it->evd = NULL;
    }
    free(sig);
    free(evd);
}

static void to_cache(const bench_plan *p, const bench_outputs *o, uint64_t key)
{
    for (int f = 0; f <= BENCH_FEATURES_COUNT; f++) {
        char *path = cache_path(p, key, f);
        if (f < BENCH_FEATURES_COUNT && o->sig[f])
            cache_store(path, o->sig[f]);
        else if (f == BENCH_FEATURES_COUNT)
            cache_store_evd(path, o->evd);
        free(path);
    }
}

/* The item's signature (with --descriptor evd: HKS's, and the
 * eigenvalues). A comparison run with a cache computes and stores every
 * output of the version's spectrum, so that the other rows' runs read
 * them instead of solving again. */
static phks_status compute_outputs(const bench_plan *p, bench_item *it,
                                   const phks_mesh *mesh, uint64_t key,
                                   const char **reason)
{
    int all = p->cache_dir && (p->features != BENCH_FEATURES_HKS || p->evd);
    bench_outputs o = {{NULL}, NULL};
    phks_status st = bench_outputs_compute(
        p, mesh, all ? (1u << BENCH_FEATURES_COUNT) - 1 : 1u << p->features,
        all || p->evd, &o);
    if (st == PHKS_OK && p->cache_dir)
        to_cache(p, &o, key);
    if (st == PHKS_OK && p->evd && !o.evd) {
        *reason = "fewer nonzero eigenvalues than the descriptor's 50";
        st = PHKS_ERROR_INVALID_ARGUMENT;
    }
    if (st == PHKS_OK) {
        it->sig = o.sig[p->features];
        o.sig[p->features] = NULL;
        if (p->evd) {
            it->evd = o.evd;
            o.evd = NULL;
        }
    }
    bench_outputs_free(&o);
    return st;
}

static phks_status compute(bench_plan *p, bench_item *it, uint64_t seed,
                           const char **reason)
{
    const bench_model *model = &p->models[it->model];
    phks_mesh *src = NULL, *mesh = NULL;
    piece pc = {0};
    uint64_t key = 0;
    phks_status st = bench_load(model, &src, reason);
    if (st == PHKS_OK && it->kind == KIND_COMPLETE)
        mesh = src;
    else if (st == PHKS_OK)
        st = make_version(src, it->kind, seed, &pc, &mesh, reason);
    if (st == PHKS_OK && p->cache_dir) {
        key = cache_key(p, it, seed, mesh);
        from_cache(p, it, key);
    }
    if (st == PHKS_OK && !it->cached)
        st = compute_outputs(p, it, mesh, key, reason);
    if (st == PHKS_OK && model->is_query && it->kind != KIND_COMPLETE)
        count_near_cut(src, &pc, mesh, it);
    if (st == PHKS_OK && p->source && it->kind != KIND_COMPLETE &&
        !(it->truth = trace_features(&pc, mesh, it->sig)))
        st = PHKS_ERROR_OUT_OF_MEMORY;
    if (mesh != src)
        phks_mesh_free(mesh);
    phks_mesh_free(src);
    piece_free(&pc);
    return st;
}

void bench_compute(void *ctx, size_t index)
{
    bench_plan *p = ctx;
    bench_item *it = &p->items[index];
    const char *path = p->models[it->model].row->path;
    uint64_t seed = it->kind == KIND_COMPLETE
        ? 0 : bench_seed(it->seed, p->models[it->model].row->file, it->kind);
    const char *reason = NULL;
    phks_status st = compute(p, it, seed, &reason);
    if (st != PHKS_OK && !reason)
        reason = cli_reason(path, st);
    if (st != PHKS_OK && it->kind == KIND_COMPLETE)
        cli_say(stderr, "phks: %s: %s\n", path, reason);
    else if (st != PHKS_OK)
        cli_say(stderr, "phks: %s: %s version of seed %u: %s\n", path,
                bench_kind_name[it->kind], it->seed, reason);
    cli_progress_step();
}

int bench_make_cache(const char *dir)
{
    if (dir && mkdir(dir, 0777) != 0 && errno != EEXIST)
        return cli_error(dir, strerror(errno));
    return 0;
}

void bench_compute_all(bench_plan *plan, unsigned workers)
{
    cli_blas_one_thread();
    cli_progress_start(plan->item_count, "signatures");
    cli_pool_run(plan->item_count, workers, bench_compute, plan);
    cli_progress_end();
}

void bench_print_footer(const bench_plan *p, double seconds, int json)
{
    size_t computed = 0, cached = 0, failed = 0;
    for (size_t i = 0; i < p->item_count; i++) {
        const bench_item *it = &p->items[i];
        failed += !it->sig;
        cached += it->sig && it->cached;
        computed += it->sig && !it->cached;
    }
    if (json) {
        printf(",\n  \"signatures\": {\"computed\": %zu, \"cached\": %zu, "
               "\"failed\": %zu},\n  \"wall_seconds\": ", computed, cached,
               failed);
        cli_json_number(seconds);
        fputs("\n}\n", stdout);
        return;
    }
    printf("\nSignatures: %zu computed, %zu from the cache, %zu failed; wall "
           "time %.1f s.\n", computed, cached, failed, seconds);
}
