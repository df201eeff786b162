/*
 * lanczos.h - the block Lanczos solver's own pieces (lanczos*.c): the
 * operator laid out for block products, the Gram-Schmidt products, the
 * Ritz vectors' product, and the solver's workspace and steps shared
 * between its files. Private to the eigen layer.
 */
#ifndef PHKS_LANCZOS_H
#define PHKS_LANCZOS_H

#include "eigen/eigen.h"
#include "core/simd.h"

#include <lapacke.h>

/* ---- the operator laid out for block products (lanczos_pairs.c) */
/* Rows taken two at a time in op->order (the identity without one): pair g
 * holds rows 2g and 2g + 1 of P B P^T, where row r is point order[r], as
 * one list of columns (numbered in the same order) with two values per
 * entry, zero where the column belongs to one row only. Products on
 * row-major n x PHKS__PAIR_BLOCK blocks in that numbering. */
#define PHKS__PAIR_BLOCK 16
#define PHKS__PAIR_MAX_THREADS 64
/* Pair ranges of about equal entry counts per thread, taken by the
 * team's threads as they become free (parallel.c). */
#define PHKS__PAIR_PARTS_PER_THREAD 8
typedef struct phks__operator_pairs {
    size_t n, pairs;        /* rows, (n + 1) / 2 pairs                  */
    uint32_t *order;        /* n: row r is point order[r] of the operator */
    size_t *start;          /* pairs + 1 offsets into the columns       */
    uint32_t *col;          /* the columns, when n > 65536 ...          */
    uint16_t *col16;        /* ... or here: one of the two is NULL      */
    double *val;            /* 2 per entry: rows 2g and 2g + 1          */
    unsigned threads;       /* products run on this many threads,      */
    unsigned parts;         /* on this many pair ranges of about equal  */
    size_t bound[PHKS__PAIR_MAX_THREADS * PHKS__PAIR_PARTS_PER_THREAD + 1];
                            /* entry counts: part t is bound[t] ..     */
} phks__operator_pairs;

phks_status phks__operator_pairs_build(const phks__operator_matrix *op,
                                      unsigned threads, phks__operator_pairs *pm);
void phks__operator_pairs_release(phks__operator_pairs *pm);
/* out = alpha (P B P^T) x + gamma x + beta z on row-major n x
 * PHKS__PAIR_BLOCK blocks (z may be NULL; out distinct from x and z).
 * Bit-identical for any thread count; avx2 from phks__cpu_avx2 (simd.h)
 * (the portable kernel rounds differently). */
void phks__operator_pairs_poly(const phks__operator_pairs *pm, bool avx2,
                              const double *x, const double *z, double *out,
                              double alpha, double gamma, double beta);

/* ---- the Ritz vectors' product (lanczos_ritz.c) */
/* x = v s: v n x m, s m x k, x n x k, column-major with leading dimensions
 * n, m, n; on `threads` threads, the same bits for any count. */
phks_status phks__ritz_product(const double *v, size_t n, size_t m, const double *s,
                              size_t k, double *x, unsigned threads, bool avx2);

/* ---- Gram-Schmidt products (lanczos_gram.c) */
/* C = V^T W, then W -= V C, where V is n x cnt column-major (leading
 * dimension n), W n x PHKS__PAIR_BLOCK row-major and C cnt x
 * PHKS__PAIR_BLOCK row-major. Bit-identical for any thread count; avx2 from
 * phks__cpu_avx2 (simd.h). */
void phks__block_project(const double *v, size_t n, size_t cnt, double *w,
                        double *c, unsigned threads, bool avx2);
/* g = W^T W (PHKS__PAIR_BLOCK^2, full) for the row-major n x
 * PHKS__PAIR_BLOCK block w, through phks__block_gram_parts(n) partial sums
 * over fixed stretches of rows (parts holds that many blocks of
 * PHKS__PAIR_BLOCK^2): bit-identical for any thread count. */
size_t phks__block_gram_parts(size_t n);
void phks__block_gram(const double *w, size_t n, double *parts, double *g,
                     unsigned threads, bool avx2);
/* W := W U for the row-major block w and U upper triangular
 * (PHKS__PAIR_BLOCK^2, row-major). */
void phks__block_times_upper(double *w, size_t n, const double *u,
                            unsigned threads, bool avx2);

/* ---- the block Lanczos solver (lanczos*.c) */

#define PHKS__LANCZOS_BLOCK PHKS__PAIR_BLOCK

/* B's null space in the pair numbering (lanczos_null.c): one unit vector
 * per component of the kernel's graph, row r's entry z[r] in the vector of
 * component[r]. */
typedef struct phks__lanczos_null {
    size_t count;           /* components                                */
    uint32_t *component;    /* n                                         */
    double *z;              /* n                                         */
    double *coef;           /* count x PHKS__LANCZOS_BLOCK: scratch      */
} phks__lanczos_null;

/* The operator's products as the solver runs them; with null, on the
 * orthogonal complement of B's null space (every new block projected). */
typedef struct phks__lanczos_engine {
    const phks__operator_pairs *pm;
    bool avx2;
    const phks_options *opt;
    double fraction;        /* progress reported between products */
    const phks__lanczos_null *null; /* NULL: the whole space        */
} phks__lanczos_engine;

/* The filter p(B) = T_d((c I - B) / e) (degree 1 with c = 0, e = 1: -B,
 * which spans the same Krylov space as B). */
typedef struct phks__lanczos_filter {
    int degree;
    double c, e;
} phks__lanczos_filter;

/* The basis and T with their workspace; columns grow geometrically up to
 * cap. */
typedef struct phks__lanczos {
    size_t n, k, b;
    bool local;             /* re-orthogonalise against the last two blocks
                               only (the probe)                              */
    size_t cap;             /* most basis columns allowed                    */
    size_t room;            /* basis columns allocated so far                */
    double *v;              /* n x room, column-major basis                  */
    double *t;              /* room x room, V^T p(B) V (upper triangle)      */
    double *w;              /* n x b residual block                          */
    double *keep;           /* n x b copy of w for repairs                   */
    double *rows[3];        /* n x b row-major blocks for the operator       */
    double *c;              /* room x b projection coefficients              */
    double *tau;            /* b Householder scalars                         */
    double *ritz;           /* room x room eigenvectors of T                 */
    double *theta;          /* room eigenvalues of T                         */
    lapack_int *support;    /* 2 room, for dstemr                            */
    double *tfull;          /* room x room: T, then its tridiagonal reduction */
    double *diag, *off, *reflect; /* room each: T's tridiagonal form and
                               the reflectors' scalars                       */
    double *diag_work, *off_work; /* room each: its copy for dstemr          */
    double *edge;           /* room x b: Q^T of the last b unit vectors      */
    double *gram_parts;     /* partial Gram matrices of Cholesky QR          */
    double *saved;          /* n x b row-major: the block before its QR      */
    double *bottom;         /* b x room: last b rows of T's eigenvectors     */
} phks__lanczos;

/* What a block step applies: the filter, through the engine. */
typedef struct phks__lanczos_run {
    const phks__lanczos_engine *eng;
    const phks__lanczos_filter *f;
} phks__lanczos_run;

/* Where the extraction leaves the k lowest eigenpairs of B: values
 * ascending, vectors column-major n x k, worst a bound on their largest
 * residual |B x - lambda x|, next an upper estimate of lambda_{k+1}
 * (Rayleigh-Ritz sets it; the caller otherwise). */
typedef struct phks__lanczos_out {
    double *values, *vectors;
    double worst, next;
} phks__lanczos_out;

/* lanczos_filter.c: column-major n x BLOCK <-> row-major blocks; p(B) on a
 * column-major block, left row-major in one of r[0..2] (*result) or
 * written column-major to out; the eigenvalue of B that p maps to theta. */
void phks__lanczos_to_rows(const phks__lanczos_engine *e, const double *cols,
                           double *rows, size_t n);
void phks__lanczos_to_cols(const phks__lanczos_engine *e, const double *rows,
                           double *cols, size_t n);
phks_status phks__lanczos_apply_rows(const phks__lanczos_engine *e,
                                      const phks__lanczos_filter *f,
                                      const double *in, double *r[3], size_t n,
                                      double **result);
phks_status phks__lanczos_apply(const phks__lanczos_engine *e,
                                 const phks__lanczos_filter *f,
                                 const double *in, double *out, double *r[3],
                                 size_t n);
double phks__lanczos_filter_inverse(const phks__lanczos_filter *f,
                                    double theta);

/* lanczos_basis.c: the workspace; a fixed random block; Householder QR of
 * a block (*smallest: its weakest direction, relative); one block step of
 * the recurrence (W = p(B) V_last, orthogonalised, the next block in L->w
 * and its coupling in r). */
void phks__lanczos_release(phks__lanczos *L);
phks_status phks__lanczos_reserve(phks__lanczos *L, size_t columns);
phks_status phks__lanczos_allocate(phks__lanczos *L, size_t first);
void phks__lanczos_random_block(double *w, size_t n, size_t b, uint64_t seed);
phks_status phks__lanczos_qr(phks__lanczos *L, double *w, double *r,
                             double *smallest);
phks_status phks__lanczos_step(phks__lanczos *L, const phks__lanczos_run *rc,
                               size_t m, double *r);

/* lanczos_null.c: the components of op's kernel graph and their null
 * vectors in pm's numbering; the projection of a row-major n x
 * PHKS__LANCZOS_BLOCK block or of `cols` column-major columns onto their
 * orthogonal complement; the first `count` null vectors as the columns of
 * vectors (n x count). */
phks_status phks__lanczos_null_build(const phks__operator_matrix *op,
                                     const phks__operator_pairs *pm,
                                     phks__lanczos_null *z);
void phks__lanczos_null_release(phks__lanczos_null *z);
void phks__lanczos_null_rows(const phks__lanczos_null *z, double *wr, size_t n);
void phks__lanczos_null_cols(const phks__lanczos_null *z, double *w, size_t n,
                             size_t cols);
void phks__lanczos_null_vectors(const phks__lanczos_null *z, size_t count,
                                double *vectors, size_t n);

/* lanczos_tridiag.c: T's tridiagonal reduction and its eigenpairs il..iu
 * (1-based), both at once (eig_t); Ritz vectors of T; a Ritz pair's
 * residual; the convergence check at basis size m. */
phks_status phks__lanczos_reduce_t(phks__lanczos *L, size_t m);
phks_status phks__lanczos_pairs_t(phks__lanczos *L, size_t m, size_t il,
                                  size_t iu, bool vectors);
phks_status phks__lanczos_eig_t(phks__lanczos *L, size_t m, size_t il,
                                size_t iu);
phks_status phks__lanczos_ritz_vectors(phks__lanczos *L, size_t m,
                                       size_t first, size_t count);
double phks__lanczos_ritz_residual(const phks__lanczos *L, const double *r,
                                   size_t e);
phks_status phks__lanczos_check(phks__lanczos *L, const double *r, size_t m,
                                size_t q, size_t k, double scale,
                                double *excess);

/* lanczos_extract.c: the k lowest eigenpairs of B from the converged
 * basis: Ritz vectors as they are, with a sketched bound on their
 * residuals (*worst), or Rayleigh-Ritz with B on the top q. */
phks_status phks__lanczos_ritz_pairs(phks__lanczos *L,
                                     const phks__lanczos_engine *eng,
                                     const phks__lanczos_filter *f, size_t m,
                                     size_t q, size_t k,
                                     phks__lanczos_out *out);
phks_status phks__lanczos_rayleigh_ritz(phks__lanczos *L,
                                        const phks__lanczos_engine *eng,
                                        size_t m, size_t q, size_t k,
                                        phks__lanczos_out *out);

#endif /* PHKS_LANCZOS_H */
