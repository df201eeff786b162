/*
 * lanczos.h - the block Lanczos solver's own pieces (lanczos.c): the
 * operator laid out for block products, the Gram-Schmidt products and the
 * Ritz vectors' product. Private to the eigen layer.
 */
#ifndef PHKS_LANCZOS_H
#define PHKS_LANCZOS_H

#include "eigen/eigen.h"
#include "core/simd.h"

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

#endif /* PHKS_LANCZOS_H */
