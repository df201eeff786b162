/*
 * internal.h - declarations shared by the library's own files. Nothing here
 * is exported; tests reach it through the build's internal dependency.
 */
#ifndef PHKS_INTERNAL_H
#define PHKS_INTERNAL_H

#include "phks.h"

#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#if defined(__GNUC__) || defined(__clang__)
#define PHKS_PRINTF(f, a) __attribute__((format(printf, f, a)))
#else
#define PHKS_PRINTF(f, a)
#endif

#define PHKS_PI 3.14159265358979323846

/* ---- allocation (alloc.c): every library allocation goes through here */
void *phks_malloc(size_t size);
void *phks_calloc(size_t count, size_t size); /* zeroed, overflow-checked */
void *phks_realloc(void *ptr, size_t size);
void phks_free(void *ptr);
/* count * size bytes, NULL on overflow or failure. */
void *phks_malloc_array(size_t count, size_t size);
void *phks_realloc_array(void *ptr, size_t count, size_t size);

/* ---- errors (error.c) */
/* Records a printf-style detail for phks_last_error_message() in the
 * calling thread and returns status, so a failure is one line:
 *     return phks_fail(PHKS_ERROR_PARSE, "line %zu: ...", line); */
phks_status phks_fail(phks_status status, const char *fmt, ...)
    PHKS_PRINTF(2, 3);
/* The common case of a failed allocation. */
phks_status phks_fail_oom(const char *what);
/* Prefixes the current thread's message with "prefix: " (used to add a
 * file name to a reader's message). */
void phks_error_prefix(const char *prefix);

/* ---- options (options.c) */
/* Validates user options (NULL means defaults) into *out. Returns
 * PHKS_ERROR_INVALID_ARGUMENT with a message naming the bad field. */
phks_status phks_options_resolve(const phks_options *user, phks_options *out);
/* Reports progress; returns PHKS_ERROR_CANCELLED when the callback asks. */
phks_status phks_progress(const phks_options *opt, phks_stage stage,
                          double fraction);

/* ---- mesh (mesh.c) */
struct phks_mesh {
    size_t vertex_count;
    size_t triangle_count;
    double *xyz;             /* 3 per vertex, input coordinates          */
    uint32_t *triangles;     /* 3 per triangle                           */
    uint32_t *vertex_origin; /* input index of each vertex               */
    double area;             /* total area                               */

    /* Edges: unique unordered vertex pairs, sorted by (lower, higher). */
    size_t edge_count;
    uint32_t *edge_vertices;      /* 2 per edge                          */
    uint32_t *edge_tri_offset;    /* edge_count + 1 offsets into edge_tris */
    uint32_t *edge_tris;          /* triangles incident to each edge,
                                     ascending                            */
    uint32_t *triangle_edges;     /* 3 per triangle: edge of corners
                                     (0,1), (1,2), (2,0)                  */

    size_t boundary_edge_count;
    uint32_t *boundary_edges;     /* 2 per boundary edge                 */
    size_t component_count;
    uint32_t *vertex_component;
};

/* Area of the triangle with corners a, b, c (3 doubles each). */
double phks_triangle_area(const double *a, const double *b, const double *c);

/* Builds a mesh from arrays the caller keeps ownership of. vertex_origin
 * may be NULL (identity). Cleans as phks_mesh_create documents. */
phks_status phks_mesh_build(const double *xyz, size_t vertex_count,
                            const uint32_t *triangles, size_t triangle_count,
                            const uint32_t *vertex_origin, phks_mesh **out);

/* ---- readers (read_*.c): parse a whole in-memory file into arrays.
 * On success *xyz and *tri are library allocations owned by the caller.
 * Errors carry a message with a line number (text) or byte offset
 * (binary), without the file name (the loader adds it). */
typedef struct phks_raw_mesh {
    double *xyz;
    size_t vertex_count;
    uint32_t *triangles;
    size_t triangle_count;
    uint32_t *vertex_origin; /* NULL for identity; set by welding readers */
} phks_raw_mesh;

void phks_raw_mesh_release(phks_raw_mesh *raw);
phks_status phks_read_off(const char *data, size_t size, phks_raw_mesh *raw);
phks_status phks_read_obj(const char *data, size_t size, phks_raw_mesh *raw);
phks_status phks_read_ply(const char *data, size_t size, phks_raw_mesh *raw);
phks_status phks_read_stl(const char *data, size_t size, phks_raw_mesh *raw);

/* ---- normalisation (normalize.c) */
/* Scale factor s such that s * positions fit the unit box of `box`. */
phks_status phks_unit_box_scale(const phks_mesh *mesh, phks_box box,
                                double *scale);
/* Per-vertex area: a third of the area of the incident triangles, for
 * positions scaled by `scale`. mass has vertex_count entries. */
void phks_vertex_areas(const phks_mesh *mesh, double scale, double *mass);
/* area[s] = the area (vertex_area summed) of the vertices within
 * straight-line distance sqrt(radius2[s]) of `vertex`, positions scaled by
 * `scale`: what PHKS_HKS_SCALING_LOCAL_AREA multiplies HKS by
 * (local_area.c). The radii in any order. */
void phks_local_areas(const phks_mesh *mesh, double scale,
                      const double *vertex_area, uint32_t vertex,
                      const double *radius2, size_t count, double *area);
/* Eigen-decomposition of the symmetric 3 x 3 matrix (row-major; its upper
 * triangle is read) by cyclic Jacobi, in the layout of LAPACK's row-major
 * dsyev: values ascending, vectors[3 * i + j] component i of the unit
 * eigenvector j, the columns orthonormal. Each vector's entry of largest
 * magnitude (the first of equals) is positive. A diagonal matrix gives
 * the unit vectors, in the order of its sorted diagonal. The same bits on
 * every run, whatever the BLAS threads; finite input assumed. */
void phks_sym3_eigen(const double matrix[9], double values[3],
                     double vectors[9]);
/* The same with progress in `stage` from done to done + span through opt
 * (NULL: none), every 2^18 triangles or vertices (a tenth of a second for
 * a million vertices takes a few reports); they return
 * PHKS_ERROR_CANCELLED when the callback asks. The numbers are the
 * same. */
phks_status phks_unit_box_scale_progress(const phks_mesh *mesh, phks_box box,
                                         const phks_options *opt,
                                         phks_stage stage, double done,
                                         double span, double *scale);
phks_status phks_vertex_areas_progress(const phks_mesh *mesh, double scale,
                                       const phks_options *opt,
                                       phks_stage stage, double done,
                                       double span, double *mass);

/* ---- persistence (persistence.c) */
/* phks_persistent_maxima with progress: reports PHKS_STAGE_PERSISTENCE
 * fractions from done to done + span through opt (NULL: none) at the
 * start of each phase and every 65,536 triangles, edges or merges inside
 * one (dozens of times a second on a million vertices; a count that
 * depends on the mesh and f alone), and returns PHKS_ERROR_CANCELLED,
 * everything freed and *count 0, when the callback asks. The results are
 * those of phks_persistent_maxima, bit for bit. */
phks_status phks_persistence_run(const phks_mesh *mesh, const double *f,
                                 size_t max_count, double threshold,
                                 phks_maximum *out, size_t *count,
                                 uint32_t *region_of_triangle,
                                 const phks_options *opt, double done,
                                 double span);

/* ---- spatial grid (grid.c) */
typedef struct phks_grid {
    double origin[3];
    double cell;           /* cell edge length */
    size_t dims[3];
    size_t *cell_start;    /* dims product + 1 offsets into points    */
    uint32_t *points;      /* point indices sorted by cell           */
} phks_grid;

/* Buckets n points (xyz, scaled by `scale`) into cells of size `cell`. */
phks_status phks_grid_build(const double *xyz, size_t n, double scale,
                            double cell, phks_grid *grid);
void phks_grid_release(phks_grid *grid);
/* The cell of the (scaled) point p, clamped to the grid. */
void phks_grid_cell(const phks_grid *grid, const double p[3], size_t c[3]);
/* The points of cell c and the 26 around it as ranges [first, last) of
 * grid->points, in a fixed order (z, then y; x ascending within each):
 * returns how many ranges (at most 9, fewer at the grid's faces). */
size_t phks_grid_neighbourhood(const phks_grid *grid, const size_t c[3],
                               size_t range[9][2]);

/* ---- boundary proximity (boundary.c) */
/* distance[v] = straight-line distance from vertex v to the nearest vertex
 * on a boundary edge, positions scaled by scale, capped at cap (cap > 0;
 * all cap on a closed mesh). Runs on phks_thread_count(opt) threads (the
 * distances do not depend on it) and reports progress in `stage` from
 * done to done + span through opt (NULL: one thread, no reports) between
 * batches of vertices; returns PHKS_ERROR_CANCELLED when the callback
 * asks. */
phks_status phks_boundary_distance(const phks_mesh *mesh, double scale,
                                   double cap, const phks_options *opt,
                                   phks_stage stage, double done, double span,
                                   double *distance);

/* ---- sparse symmetric operator (laplacian.c) */
/* The symmetric matrix B = Mh^-1/2 S Mh^-1/2 in CSR form (both triangles
 * stored, diagonal included), where Mh is the mass diagonal (area, or
 * area times kernel density for the random-walk operator). The eigenpairs
 * of B give those of S phi = lambda Mh phi by phi = Mh^-1/2 x. */
typedef struct phks_operator_matrix {
    size_t n;
    size_t *row_start;   /* n + 1 */
    uint32_t *col;
    double *val;
    double *mass;        /* Mh, n entries */
    double norm_bound;   /* Gershgorin bound on |B| */
    uint32_t *order;     /* the points in Morton order of their positions
                            (n entries; NULL: no locality order known)  */
} phks_operator_matrix;

phks_status phks_operator_build(const phks_mesh *mesh, const phks_options *opt,
                                phks_operator_matrix *op);
void phks_operator_release(phks_operator_matrix *op);
/* The matrix phks_operator_build makes for a mesh, for points at xyz
 * (3 per point, multiplied by scale) with masses area[] in place of the
 * vertex areas, and K_pq multiplied by sqrt(gain_p gain_q) when gain is
 * not NULL. Progress in PHKS_STAGE_OPERATOR from done to done + span (the
 * final report, at done + span, included). */
phks_status phks_point_operator_build(const double *xyz, size_t n,
                                      double scale, const double *area,
                                      const double *gain,
                                      const phks_options *opt, double done,
                                      double span, phks_operator_matrix *op);
/* Y = B X for a block of k vectors stored row-major (X[i*k + j] is entry i
 * of vector j), using `threads` workers. */
void phks_operator_apply(const phks_operator_matrix *op, const double *x,
                         double *y, size_t k, unsigned threads);

/* ---- the operator laid out for block products (operator_pairs.c) */
/* Rows taken two at a time in op->order (the identity without one): pair g
 * holds rows 2g and 2g + 1 of P B P^T, where row r is point order[r], as
 * one list of columns (numbered in the same order) with two values per
 * entry, zero where the column belongs to one row only. Products on
 * row-major n x PHKS_PAIR_BLOCK blocks in that numbering. */
#define PHKS_PAIR_BLOCK 16
#define PHKS_PAIR_MAX_THREADS 64
/* Pair ranges of about equal entry counts per thread, taken by the
 * team's threads as they become free (parallel.c). */
#define PHKS_PAIR_PARTS_PER_THREAD 8
typedef struct phks_operator_pairs {
    size_t n, pairs;        /* rows, (n + 1) / 2 pairs                  */
    uint32_t *order;        /* n: row r is point order[r] of the operator */
    size_t *start;          /* pairs + 1 offsets into the columns       */
    uint32_t *col;          /* the columns, when n > 65536 ...          */
    uint16_t *col16;        /* ... or here: one of the two is NULL      */
    double *val;            /* 2 per entry: rows 2g and 2g + 1          */
    unsigned threads;       /* products run on this many threads,      */
    unsigned parts;         /* on this many pair ranges of about equal  */
    size_t bound[PHKS_PAIR_MAX_THREADS * PHKS_PAIR_PARTS_PER_THREAD + 1];
                            /* entry counts: part t is bound[t] ..     */
} phks_operator_pairs;

phks_status phks_operator_pairs_build(const phks_operator_matrix *op,
                                      unsigned threads, phks_operator_pairs *pm);
void phks_operator_pairs_release(phks_operator_pairs *pm);
/* out = alpha (P B P^T) x + gamma x + beta z on row-major n x
 * PHKS_PAIR_BLOCK blocks (z may be NULL; out distinct from x and z).
 * Bit-identical for any thread count; avx2 from phks_cpu_avx2 (simd.h)
 * (the portable kernel rounds differently). */
void phks_operator_pairs_poly(const phks_operator_pairs *pm, bool avx2,
                              const double *x, const double *z, double *out,
                              double alpha, double gamma, double beta);

/* ---- the Ritz vectors' product (ritz_product.c) */
/* x = v s: v n x m, s m x k, x n x k, column-major with leading dimensions
 * n, m, n; on `threads` threads, the same bits for any count. */
phks_status phks_ritz_product(const double *v, size_t n, size_t m, const double *s,
                              size_t k, double *x, unsigned threads, bool avx2);

/* ---- Gram-Schmidt products (block_project.c) */
/* C = V^T W, then W -= V C, where V is n x cnt column-major (leading
 * dimension n), W n x PHKS_PAIR_BLOCK row-major and C cnt x
 * PHKS_PAIR_BLOCK row-major. Bit-identical for any thread count; avx2 from
 * phks_cpu_avx2 (simd.h). */
void phks_block_project(const double *v, size_t n, size_t cnt, double *w,
                        double *c, unsigned threads, bool avx2);
/* g = W^T W (PHKS_PAIR_BLOCK^2, full) for the row-major n x
 * PHKS_PAIR_BLOCK block w, through phks_block_gram_parts(n) partial sums
 * over fixed stretches of rows (parts holds that many blocks of
 * PHKS_PAIR_BLOCK^2): bit-identical for any thread count. */
size_t phks_block_gram_parts(size_t n);
void phks_block_gram(const double *w, size_t n, double *parts, double *g,
                     unsigned threads, bool avx2);
/* W := W U for the row-major block w and U upper triangular
 * (PHKS_PAIR_BLOCK^2, row-major). */
void phks_block_times_upper(double *w, size_t n, const double *u,
                            unsigned threads, bool avx2);

/* ---- eigen-solvers (eigen_*.c): the k smallest eigenpairs of op's B.
 * values ascending (k), vectors column-major n x k, orthonormal in the
 * plain inner product. *next (next may be NULL) receives an estimate of
 * lambda_{k+1} that is not below it (INFINITY when k = n or unknown), which
 * tells whether the k-th value ends a cluster (spectrum.c). */
phks_status phks_eigen_lanczos(const phks_operator_matrix *op, size_t k,
                               const phks_options *opt, double *values,
                               double *vectors, double *next);
phks_status phks_eigen_arpack(const phks_operator_matrix *op, size_t k,
                              const phks_options *opt, double *values,
                              double *vectors, double *next);
phks_status phks_eigen_dense(const phks_operator_matrix *op, size_t k,
                             const phks_options *opt, double *values,
                             double *vectors, double *next);

/* ---- B's null space (spectrum.c) */
/* The connected components of the graph of op's non-zero off-diagonal
 * entries (the kernel's, which may split a connected mesh): *component
 * (a library allocation, n entries) numbers them 0.. in order of lowest
 * point, *count is their number. S is a graph Laplacian with positive
 * weights on those entries, so B's null space is exactly spanned by
 * Mh^1/2 times the indicator of each component. */
phks_status phks_operator_components(const phks_operator_matrix *op,
                                     uint32_t **component, size_t *count);
/* root[i] = sqrt(Mh_i) and scale[c] = 1 / sqrt(Mh of component c): the
 * unit null vector of component c is root[i] scale[c] on its points. */
phks_status phks_null_space(const phks_operator_matrix *op,
                            const uint32_t *component, size_t count,
                            double *root, double *scale);
/* Eigenvalues within this fraction of max(|lambda|, 1 / tau) of each
 * other are equal: a spectrum keeps whole clusters of them (phks.h). */
#define PHKS_CLUSTER_TOL 1e-6

/* ---- spectrum (spectrum.c, hks.c; HKS-simp in simp.h) */
struct phks_spectrum {
    size_t n, count;      /* n: the mesh's vertex count               */
    double *values;       /* count, ascending                         */
    double *vectors;      /* rows x count column-major, Mh-orthonormal;
                             rows = n, or ext->m with HKS-simp        */
    double *mass;         /* n: Mh of every mesh vertex (with HKS-simp
                             its area times Mh / A of its sample), so
                             the sum is the total mass either way     */
    phks_options options; /* resolved options it was computed with    */
    struct phks_extension *ext; /* HKS-simp: the samples and what the
                             extension to every vertex needs; NULL for
                             an exact spectrum                        */
};

/* HKS_t at one vertex: sum_i exp(-t lambda_i) phi_i(v)^2 (through the
 * extension with HKS-simp). */
double phks_hks_at(const phks_spectrum *spec, double t, size_t v);
/* HKS_t at every vertex into out (n values), reporting PHKS_STAGE_HKS
 * progress through opt (its threads too); t finite and >= 0. */
phks_status phks_hks_all(const phks_spectrum *spec, double t,
                         const phks_options *opt, double *out);

/* ---- signature (signature.c, signature_codec.c, score.c) */
struct phks_signature {
    phks_options options;  /* what shaped the numbers; see
                              phks_signature_compatible                 */
    size_t count, length;  /* features, vector length (scale_count)    */
    uint32_t *vertex;      /* count                                     */
    double *position;      /* 3 * count, input coordinates              */
    double *persistence;   /* count; INFINITY when unpaired             */
    double *vectors;       /* count x length, row-major                 */
};

/* An empty signature with room for count features of length values. */
phks_status phks_signature_alloc(size_t count, size_t length,
                                 phks_signature **out);
/* True when two option sets give comparable signatures: every field that
 * changes the numbers is equal (not the solver, threads or callbacks). */
bool phks_options_comparable(const phks_options *a, const phks_options *b);

/* ---- threads (parallel.c) */
/* Calls fn(ctx, begin, end) over [0, n) split into `threads` contiguous
 * chunks on worker threads (falls back to the calling thread alone). */
typedef void (*phks_range_fn)(void *ctx, size_t begin, size_t end);
void phks_parallel_for(size_t n, unsigned threads, phks_range_fn fn, void *ctx);
/* Keeps threads - 1 workers for the loops this thread starts until
 * phks_team_leave (parallel.c says why). NULL, which leave accepts, when a
 * team is entered on this thread already, threads <= 1, or nothing could
 * be started: the loops then create their threads as they go. */
typedef struct phks_team phks_team;
phks_team *phks_team_enter(unsigned threads);
void phks_team_leave(phks_team *team);
/* threads option resolved: 0 means the number of online CPUs. */
unsigned phks_thread_count(const phks_options *opt);
/* Runs fn(ctx, begin, end) over [0, n) in `batches` consecutive batches,
 * each split over `threads` workers by phks_parallel_for (so the outputs
 * never depend on the thread count when fn writes disjoint entries), and
 * reports progress in `stage` from done to done + span before each batch:
 * a cancellation is noticed within one batch. opt may be NULL. */
phks_status phks_run_batched(size_t n, unsigned threads, phks_range_fn fn,
                             void *ctx, const phks_options *opt,
                             phks_stage stage, double done, double span,
                             size_t batches);

/* ---- deterministic start vectors (random.c) */
/* Fills v with n numbers in [-0.5, 0.5) from a fixed generator started at
 * `state`: the solvers start from the same vectors on every run, so
 * results never depend on what ran before. */
void phks_random_fill(double *v, size_t n, uint64_t state);

/* ---- checksum (crc32.c via zlib) */
uint32_t phks_crc32(const void *data, size_t size);

/* ---- shape databases (db.c, db_scan.c) */
/* The packed copy of a database's entries that queries scan. Entries stay
 * in ascending id order. Entry e's feature vectors form one block at
 * vectors + vector_at[e]: `length` rows (one per scale) of
 * phks_db_padded(features[e]) values (one per feature), the padding lanes
 * +infinity. text + text_at[e] holds "name\0label\0", each cut to
 * PHKS_DB_TEXT_MAX bytes. Removed entries keep their slot with features 0
 * until more than half the slots are dead. Not locked by itself: db.c
 * guards it with a read-write lock. */
typedef struct phks_db_cache {
    size_t count, dead, capacity; /* slots used, removed, allocated     */
    size_t length;                /* vector length; 0 until the first   */
    uint32_t max_features;        /* largest features[e] ever added     */
    int64_t *ids;
    uint32_t *features;
    size_t *vector_at, *text_at;
    double *vectors;
    size_t vectors_used, vectors_capacity; /* in doubles                */
    char *text;
    size_t text_used, text_capacity;
} phks_db_cache;

/* Feature count rounded up to the scan's lane count. */
size_t phks_db_padded(size_t features);
/* An empty cache; release frees it and leaves it empty. */
void phks_db_cache_init(phks_db_cache *cache);
void phks_db_cache_release(phks_db_cache *cache);
/* Appends an entry whose id is above every id held, with vectors of the
 * same length as the others. Returns PHKS_ERROR_OUT_OF_MEMORY (the cache
 * is left as it was) or PHKS_ERROR_INVALID_ARGUMENT (id below 1 or out of
 * order, other length, no features) without setting a message: the caller,
 * whose own call may still succeed, decides what to report. */
phks_status phks_db_cache_append(phks_db_cache *cache, int64_t id,
                                 const char *name, const char *label,
                                 const phks_signature *signature);
/* Marks entry id removed (no-op if absent); compacts in place. */
void phks_db_cache_remove(phks_db_cache *cache, int64_t id);
/* The k best entries for query, as phks_db_query documents; the query's
 * vector length must be the cache's. Safe from many threads at once. */
phks_status phks_db_cache_query(const phks_db_cache *cache,
                                const phks_signature *query, size_t k,
                                phks_hit *hits, size_t *count);

#endif /* PHKS_INTERNAL_H */
