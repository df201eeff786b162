/*
 * lanczos_filter.c - the block Lanczos solver's products: the Chebyshev
 * filter p(B) applied to a block of vectors through the operator's pair
 * layout (lanczos_pairs.c), and the transposes between the basis's
 * column-major blocks and the products' row-major ones.
 */
#include "eigen/lanczos.h"

#include <cblas.h>
#include <math.h>
#include <string.h>

#define BLOCK PHKS__LANCZOS_BLOCK

/* out = alpha * (B x) + gamma * x + beta * z on row-major n x BLOCK blocks
 * (z may be NULL), in the pair matrix's numbering. */
static void poly_step(const phks__lanczos_engine *e, const double *x, const double *z,
                      double *out, double alpha, double gamma, double beta)
{
    phks__operator_pairs_poly(e->pm, e->avx2, x, z, out, alpha, gamma, beta);
}

/* Column-major n x BLOCK <-> row-major, rows split over the product's
 * threads. */
typedef struct {
    const double *from;
    double *to;
    size_t n;
} transpose_ctx;

/* In stretches of 64 rows (8 KB of the row-major side), so that each
 * cache line is fetched once. */
#define TRANSPOSE_STRETCH 64

static void to_rows_range(void *ctx, size_t begin, size_t end)
{
    const transpose_ctx *t = ctx;
    for (size_t r0 = begin; r0 < end; r0 += TRANSPOSE_STRETCH) {
        size_t r1 = end - r0 > TRANSPOSE_STRETCH ? r0 + TRANSPOSE_STRETCH : end;
        for (size_t j = 0; j < BLOCK; j++)
            for (size_t i = r0; i < r1; i++)
                t->to[i * BLOCK + j] = t->from[j * t->n + i];
    }
}

static void to_cols_range(void *ctx, size_t begin, size_t end)
{
    const transpose_ctx *t = ctx;
    for (size_t r0 = begin; r0 < end; r0 += TRANSPOSE_STRETCH) {
        size_t r1 = end - r0 > TRANSPOSE_STRETCH ? r0 + TRANSPOSE_STRETCH : end;
        for (size_t j = 0; j < BLOCK; j++)
            for (size_t i = r0; i < r1; i++)
                t->to[j * t->n + i] = t->from[i * BLOCK + j];
    }
}

void phks__lanczos_to_rows(const phks__lanczos_engine *e, const double *cols, double *rows, size_t n)
{
    transpose_ctx t = {cols, rows, n};
    phks__parallel_for(n, e->pm->threads, to_rows_range, &t);
}

void phks__lanczos_to_cols(const phks__lanczos_engine *e, const double *rows, double *cols, size_t n)
{
    transpose_ctx t = {rows, cols, n};
    phks__parallel_for(n, e->pm->threads, to_cols_range, &t);
}

/* p(B) in (column-major), left row-major in one of the three scratch blocks
 * r[0..2]: *result. */
phks_status phks__lanczos_apply_rows(const phks__lanczos_engine *e, const phks__lanczos_filter *f,
                                     const double *in, double *r[3], size_t n,
                                     double **result)
{
    phks__lanczos_to_rows(e, in, r[0], n);
    /* T_1 = (c x - B x) / e */
    poly_step(e, r[0], NULL, r[1], -1 / f->e, f->c / f->e, 0);
    double *prev = r[0], *cur = r[1], *spare = r[2];
    for (int d = 2; d <= f->degree; d++) {
        /* each product is a pass over the matrix: report between them */
        phks_status st = phks__progress(e->opt, PHKS_STAGE_EIGEN, e->fraction);
        if (st != PHKS_OK)
            return st;
        /* T_{d} = 2 (c - B)/e T_{d-1} - T_{d-2} */
        poly_step(e, cur, prev, spare, -2 / f->e, 2 * f->c / f->e, -1);
            double *t = prev;
        prev = cur;
        cur = spare;
        spare = t;
    }
    *result = cur;
    return phks__progress(e->opt, PHKS_STAGE_EIGEN, e->fraction);
}

/* out (column-major) = p(B) in (column-major). */
phks_status phks__lanczos_apply(const phks__lanczos_engine *e, const phks__lanczos_filter *f,
                                const double *in, double *out, double *r[3],
                                size_t n)
{
    double *rows;
    phks_status st = phks__lanczos_apply_rows(e, f, in, r, n, &rows);
    if (st == PHKS_OK)
        phks__lanczos_to_cols(e, rows, out, n);
    return st;
}

/* The eigenvalue of B that p maps to theta, for theta >= 1 (p(lambda) =
 * T_d((c - lambda) / e) and T_d(x) = cosh(d acosh x) for x >= 1), or any
 * theta when d = 1. Well conditioned: where acosh is steep (theta near 1),
 * cosh flattens it again. */
double phks__lanczos_filter_inverse(const phks__lanczos_filter *f, double theta)
{
    if (f->degree == 1)
        return f->c - f->e * theta;
    return f->c - f->e * cosh(acosh(theta) / f->degree);
}
