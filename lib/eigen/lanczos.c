/*
 * lanczos.c - the fast solver: block Lanczos on a Chebyshev
 * polynomial of B, with full re-orthogonalisation; the converged Ritz
 * vectors, checked against B itself.
 *
 * Why this shape. B is bounded (spectrum in [0, lmax], lmax ~ 1/tau) and we
 * want its k lowest eigenpairs, which sit in a small fraction of that
 * range. Plain Lanczos on B needs a Krylov basis several times k for that
 * (the polynomial degree it needs grows like sqrt(lmax / lambda_k)), and
 * with full re-orthogonalisation the cost is O(n m^2) in the basis size m:
 * that, not the products, dominates. Running Lanczos on p(B), where p is a
 * Chebyshev polynomial of low degree d that keeps [a, lmax] inside [-1, 1]
 * and grows fast below a (a just above lambda_k), needs a basis only a
 * little larger than k, at the price of d products per basis vector.
 *
 *  1. A short block Lanczos run on B (re-orthogonalised locally only) gives
 *     an upper bound on lmax (top Ritz value plus its residual) and, by
 *     Gauss quadrature on the random start block, an estimate of the
 *     eigenvalue count N(lambda), from which the cut a is chosen so that
 *     about k plus a margin eigenvalues lie below.
 *  2. Block Lanczos on p(B) (block BLOCK, classical Gram-Schmidt against the
 *     last two blocks twice and the whole basis once, Cholesky QR twice for
 *     each new block) until the top k + guard Ritz pairs of T = V^T p(B) V
 *     are converged (tridiagonal reduction of T and MRRR for the pairs).
 *  3. The top k Ritz vectors, with the eigenvalues of B their Ritz values
 *     stand for (p^-1), are the eigenpairs; one product with random
 *     combinations of them bounds their residuals |B x - lambda x|, which
 *     must be below tolerance * |B|; where they are not, Rayleigh-Ritz
 *     with B on the top k + guard Ritz vectors. If that fails too, Lanczos
 *     goes on; if the cut turned out to lie below lambda_k, the solve
 *     restarts with a higher one (at most three times); if the basis would
 *     grow past its cap (3 (k + guard) + 8 BLOCK), the solve falls back to
 *     plain Lanczos on B (degree 1, basis up to 12 k + 8 BLOCK), and when
 *     that does not converge either, to the dense solver if n <= 16384,
 *     to ARPACK above.
 *  Meshes too small for a Krylov basis (n < 8 BLOCK, or fewer than
 *  k + guard + 4 BLOCK usable columns, or no room for the probe) go to the
 *  dense solver directly.
 *  Where the kernel splits the mesh into more components than a block (a
 *  soup of separate pieces: that many zero eigenvalues, of which block
 *  Lanczos finds at most a block's copies, and it used to converge with
 *  the others missing), B's null space, known exactly, is deflated: the
 *  probe shows more than BLOCK zeros, the kernel's components confirm
 *  them, their null vectors are the first pairs and steps 1 to 3 run on
 *  the orthogonal complement for the others, every new block projected.
 *
 * The whole solve runs in the numbering of the operator's pair layout
 * (lanczos_pairs.c: the points in Morton order), whose kernel applies B
 * to row-major blocks of BLOCK vectors fused with the Chebyshev recurrence
 * (one pass over the matrix per degree for the whole block); the
 * Gram-Schmidt and QR products take those row-major blocks as they are
 * (lanczos_gram.c). All of these run on the library's threads, each
 * result entry summed by one thread in a fixed order, so results are
 * bit-identical between runs and for any value of the threads option; the
 * steps whose LAPACK routines rounded differently with the BLAS's thread
 * count (the QR of a block, T's tridiagonal reduction) are the library's
 * own (householder.c), so neither count moves a bit; between products
 * the solver makes no BLAS call (whose idle threads would compete with its
 * own), only in the convergence checks and the final Ritz vectors.
 *
 * This file holds the probe and the solve's course (steps 1 to 3 and the
 * fallbacks). The pieces: lanczos_filter.c (p(B) on a block),
 * lanczos_basis.c (the basis, its orthogonalisation and QR, a block step),
 * lanczos_tridiag.c (T's eigenpairs and the convergence check),
 * lanczos_extract.c (the eigenpairs of B from the basis), lanczos_null.c
 * (the null space and the projection onto its complement), and beneath them
 * lanczos_pairs.c, lanczos_gram.c and lanczos_ritz.c (the products).
 */
#include "eigen/lanczos.h"

#include <cblas.h>
#include <math.h>
#include <string.h>

#define BLOCK PHKS__LANCZOS_BLOCK

/* Steps of the first, plain Lanczos run that estimates the spectrum: the
 * fewest steps whose cuts stayed close to those of longer probes, with no
 * restart, and the least total work (products, Gram-Schmidt and checks,
 * weighed by their costs); the comparisons are in docs/benchmarks.md. */
#define PROBE_STEPS 12
/* Degree of the Chebyshev filter: chosen so that p(0) = T_d(x0) is about
 * cosh(FILTER_GROWTH), x0 = (lmax + a) / (lmax - a). With a near
 * 0.5 lmax that is degree 4, the fastest of the degrees tried (k = 300;
 * docs/benchmarks.md); when lambda_k is a smaller fraction of
 * lmax the degree grows, up to MAX_DEGREE. */
#define FILTER_GROWTH 4.9
#define MAX_DEGREE 16
/* The cut is placed where about CUT_MARGIN (k + guard) eigenvalues lie
 * below it, by the probe's estimate. */
#define CUT_MARGIN 1.2
/* The log of (largest Ritz residual / its threshold) falls at a steady
 * rate per basis column once convergence is near, slower than this one
 * on the meshes measured (docs/benchmarks.md); the second
 * check is placed by this faster rate, so that it comes early (one more
 * check) rather than late (more basis). */
#define FIRST_SLOPE 0.25
/* Largest n for which a solve that did not converge is redone densely
 * (dense.c's own limit). */
#define DENSE_FALLBACK_MAX_N 16384
/* The probe's Ritz values of B below ZERO_LEVEL lmax count as zeros. On a
 * connected mesh, whose k-th eigenvalue lies near lmax / 2 (see
 * FILTER_GROWTH), next to none lie this low, so the kernel's components
 * (a pass over every entry of B) are looked for only where more than a
 * block of them show; a soup of tiny pieces gives that many zeros within
 * a few steps. */
#define ZERO_LEVEL 1e-3

/* The dimension of the space the solve runs on: n, less the null space
 * where it runs on its complement; and the basis columns that fit in it,
 * in whole blocks. */
static size_t dimension(const phks__lanczos_engine *eng)
{
    return eng->pm->n - (eng->null ? eng->null->count : 0);
}

static size_t usable_columns(const phks__lanczos_engine *eng)
{
    return dimension(eng) - dimension(eng) % BLOCK;
}

/* A fixed random block (seed), on the complement of the null space where
 * there is one, made orthonormal: r its R, *smallest as phks__lanczos_qr. */
static phks_status start_block(phks__lanczos *L, const phks__lanczos_engine *eng,
                               uint64_t seed, double *r, double *smallest)
{
    phks__lanczos_random_block(L->v, L->n, L->b, seed);
    if (eng->null)
        phks__lanczos_null_cols(eng->null, L->v, L->n, L->b);
    return phks__lanczos_qr(L, L->v, r, smallest);
}

/* A short plain block Lanczos on B: an upper bound on lmax, the cut a
 * with about `target` eigenvalues below it and *zeros, about how many are
 * zero (Gauss quadrature estimates of the counting function from the
 * random start block, whatever the number of copies of 0 in the null
 * space). Its basis is kept orthogonal to the last two blocks only: Lanczos without full
 * re-orthogonalisation still gives the Gauss quadrature of the start
 * block's spectral measure (Greenbaum; the copies of converged Ritz values
 * share their weight), and the extreme Ritz values stay within the
 * spectrum, at a small fraction of the cost. */
static phks_status probe(phks__lanczos_engine *eng, size_t k, size_t target,
                         double *lmax, double *cut, double *zeros)
{
    size_t n = eng->pm->n, b = BLOCK, usable = usable_columns(eng);
    size_t steps = PROBE_STEPS;
    if ((steps + 1) * b > usable)
        steps = usable / b - 1;
    phks__lanczos L = {.n = n, .k = k, .b = b, .local = true, .cap = steps * b};
    phks_status st = phks__lanczos_allocate(&L, L.cap);
    double r[BLOCK * BLOCK], smallest;
    phks__lanczos_filter plain = {1, 0, 1};
    phks__lanczos_run rc = {eng, &plain};
    if (st == PHKS_OK)
        st = start_block(&L, eng, 0, r, &smallest);
    size_t m = b;
    while (st == PHKS_OK) {
        st = phks__lanczos_step(&L, &rc, m, r);
        if (st != PHKS_OK || m + b > L.cap)
            break;
        memcpy(L.v + m * n, L.w, n * b * sizeof(double));
        m += b;
        eng->fraction = 0.02 * (double)m / (double)L.cap;
    }
    if (st == PHKS_OK)
        st = phks__lanczos_eig_t(&L, m, 1, m);
    if (st == PHKS_OK)
        st = phks__lanczos_ritz_vectors(&L, m, 0, m);
    if (st == PHKS_OK) {
        /* T holds -B: eigenvalues of B are -theta, in reverse order. */
        double top = -L.theta[0];
        double res = phks__lanczos_ritz_residual(&L, r, 0);
        *lmax = (top + res) * 1.01;
        /* count estimate: n / b * sum of |first-block components|^2 (n
         * the dimension the solve runs on) */
        double count = 0, dim = (double)dimension(eng);
        *cut = *lmax;
        *zeros = 0;
        for (size_t e = m; e-- > 0;) {
            const double *s = L.ritz + e * m;
            double w = 0;
            for (size_t i = 0; i < b; i++)
                w += s[i] * s[i];
            count += w * dim / (double)b;
            if (-L.theta[e] <= ZERO_LEVEL * *lmax)
                *zeros = count;
            if (count >= (double)target) {
                *cut = -L.theta[e];
                break;
            }
        }
    }
    phks__lanczos_release(&L);
    return st;
}

/* One solve: the filter, the pairs wanted (k, and guard more that the
 * convergence check watches), the basis's cap, |B| (the tolerance is
 * relative to it), and the part [lo, hi] of the eigen stage its progress
 * covers. */
typedef struct {
    phks__lanczos_filter f;
    size_t k, guard, cap;
    double norm, lo, hi;
} solve_plan;

/* Lanczos on p(B) until the k lowest eigenpairs of B are found, into out.
 * Returns PHKS_ERROR_NO_CONVERGENCE (without a message) when the cap is
 * hit, and sets *cut_low when the cut turned out to lie below lambda_k. */
static phks_status solve(phks__lanczos_engine *eng, const solve_plan *plan,
                         const phks_options *opt, phks__lanczos_out *out,
                         bool *cut_low)
{
    const phks__lanczos_filter *f = &plan->f;
    const size_t k = plan->k, cap = plan->cap;
    const double lo = plan->lo, hi = plan->hi;
    const double *values = out->values;
    size_t n = eng->pm->n, b = BLOCK, q = k + plan->guard;
    double tol = opt->tolerance * plan->norm;
    *cut_low = false;
    phks__lanczos L = {.n = n, .k = k, .b = b, .cap = cap};
    /* Room for the basis the filtered solves end with (a small multiple
     * of q: docs/benchmarks.md): growing it means copying it. */
    phks_status st = phks__lanczos_allocate(&L, 2 * q + 4 * b);
    phks__lanczos_run rc = {eng, f};
    double r[BLOCK * BLOCK], smallest;
    if (st == PHKS_OK)
        st = start_block(&L, eng, 1, r, &smallest);
    size_t m = b, last_check = 0;
    /* filtered Lanczos converges with a basis of somewhat more than 1.5 q
     * (a first check at 1.7 q instead of 1.5 q saves a check on most
     * meshes: docs/benchmarks.md), plain Lanczos needs several times q */
    size_t next_check = (f->degree > 1 ? 17 * q / 10 : 2 * q) / b * b;
    double last_excess = 0;
    /* The polynomial's accuracy: Ritz residuals of p(B) are relative to
     * its largest value, and the wanted vectors must be accurate to about
     * the tolerance relative to the gap between p at the guard and p at
     * lambda_k. */
    double strict = 0.1;
    while (st == PHKS_OK) {
        st = phks__lanczos_step(&L, &rc, m, r);
        if (st != PHKS_OK)
            break;
        if (m >= next_check || m + b > cap) {
            double excess = INFINITY;
            st = phks__lanczos_check(&L, r, m, q, k, strict * opt->tolerance, &excess);
            if (st == PHKS_OK)
                st = phks__progress(opt, PHKS_STAGE_EIGEN, eng->fraction);
            if (st != PHKS_OK)
                break;
            bool ok = excess <= 0;
            if (ok) {
                out->worst = INFINITY;
                /* The top k Ritz vectors of T (columns q - k + 1 .. q of
                 * ritz); Rayleigh-Ritz, if it is needed, takes all q. */
                st = phks__lanczos_ritz_vectors(&L, m, 1 + q - k, k);
                if (st != PHKS_OK)
                    break;
                /* lambda_{k+1}'s estimate before ritz_vectors and
                 * Rayleigh-Ritz reuse theta: the (k+1)-th largest Ritz
                 * value of p(B) is at most p(lambda_{k+1}), so its
                 * preimage is at least lambda_{k+1}; below 1 it lies
                 * beyond the cut */
                double theta_next = L.theta[q - k];
                out->next = f->degree > 1 && !(theta_next > 1)
                            ? f->c - f->e
                            : phks__lanczos_filter_inverse(f, theta_next);
                st = phks__lanczos_ritz_pairs(&L, eng, f, m, q, k, out);
                if (st == PHKS_OK &&
                    (out->worst > tol || (f->degree > 1 && values[k - 1] >= f->c - f->e))) {
                    st = phks__lanczos_eig_t(&L, m, m - q, m);
                    if (st == PHKS_OK)
                        st = phks__lanczos_ritz_vectors(&L, m, 1, q);
                    if (st == PHKS_OK)
                        st = phks__lanczos_rayleigh_ritz(&L, eng, m, q, k, out);
                }
                if (st != PHKS_OK)
                    break;
                if (f->degree > 1 && values[k - 1] >= f->c - f->e) {
                    *cut_low = true;
                    st = PHKS_ERROR_NO_CONVERGENCE;
                    break;
                }
                if (out->worst <= tol)
                    break;
                strict *= 0.1;
            }
            /* Next check where the log excess reaches 0, extrapolated
             * linearly from the last two checks, or from this one at
             * FIRST_SLOPE; at most m / 4 ahead. After a Rayleigh-Ritz that
             * failed, the threshold is 10 times stricter. */
            if (ok)
                excess += log(10);
            double need = (double)(m / 4);
            if (isfinite(excess)) {
                double slope = FIRST_SLOPE;
                if (last_check && excess < last_excess)
                    slope = (last_excess - excess) / (double)(m - last_check);
                need = fmin(need, excess / slope);
            }
            size_t ahead = need > (double)b ? (size_t)ceil(need / (double)b) * b : b;
            last_check = m;
            last_excess = excess;
            next_check = m + ahead;
        }
        if (m + b > cap) {
            st = PHKS_ERROR_NO_CONVERGENCE;
            break;
        }
        st = phks__lanczos_reserve(&L, m + b);
        if (st != PHKS_OK)
            break;
        memcpy(L.v + m * n, L.w, n * b * sizeof(double));
        m += b;
        double frac = (double)m / (double)(2 * q);
        eng->fraction = lo + (hi - lo) * (frac < 1 ? frac : 1);
    }
    phks__lanczos_release(&L);
    return st;
}

/* Basis sizes for a solve of k pairs in a space of dimension dim, sized
 * for `asked` pairs: the guard pairs the convergence check watches and the
 * basis's cap. Plain Lanczos may need a basis of up to about 12 asked;
 * Lanczos on the filter about 2 asked. False when dim leaves too little
 * room: the dense solve is exact and cheap there. */
static bool plan_sizes(size_t dim, size_t asked, size_t k, size_t *guard,
                       size_t *cap)
{
    size_t b = BLOCK, usable = dim - dim % b;
    *guard = asked / 8 + 2 * b;
    *cap = 12 * asked + 8 * b;
    if (*cap > usable - b)
        *cap = usable - b;
    return dim >= 8 * b && *cap >= k + *guard + 4 * b &&
           (PROBE_STEPS + 1) * b <= usable;
}

/* The filtered solves from the probe's lmax and cut, then plain Lanczos
 * when they do not converge. */
static phks_status solve_probed(phks__lanczos_engine *eng, size_t k,
                                size_t guard, size_t cap, double norm,
                                double lmax, double cut,
                                const phks_options *opt, phks__lanczos_out *out)
{
    size_t b = BLOCK;
    bool cut_low = false;
    phks_status st = PHKS_ERROR_NO_CONVERGENCE;
    for (int attempt = 0; attempt < 3 && cut > 0 && cut < lmax; attempt++) {
        double d = round(FILTER_GROWTH / acosh((lmax + cut) / (lmax - cut)));
        int degree = d < 2 ? 2 : d > MAX_DEGREE ? MAX_DEGREE : (int)d;
        size_t fcap = 3 * (k + guard) + 8 * b;
        solve_plan plan = {{degree, (lmax + cut) / 2, (lmax - cut) / 2}, k,
                           guard, fcap < cap ? fcap : cap, norm, 0.02, 0.9};
        st = solve(eng, &plan, opt, out, &cut_low);
        if (st != PHKS_ERROR_NO_CONVERGENCE || !cut_low)
            break;
        cut = cut + 2 * (out->values[k - 1] - cut) + 0.05 * (lmax - cut);
    }
    if (st != PHKS_ERROR_NO_CONVERGENCE)
        return st;
    /* plain Lanczos on B */
    solve_plan plain = {{1, 0, 1}, k, guard, cap, norm, 0.02, 1};
    return solve(eng, &plain, opt, out, &cut_low);
}

/* B's null space z deflated: its first k vectors are the first pairs
 * (exactly 0), and Lanczos on its orthogonal complement finds the others.
 * Block Lanczos finds at most a block's copies of a multiple eigenvalue
 * (further ones only as rounding lets them in, too slowly for hundreds:
 * it converged with zeros missing), and the null space has one copy of 0
 * per component. The basis is sized for all k pairs, as without the
 * deflation: past the zeros the spectrum is the union of the pieces', as
 * crowded as there are pieces (300 small spheres: sized for the 100
 * pairs past the zeros, neither solve converged). */
static phks_status solve_deflated(phks__lanczos_engine *eng,
                                  const phks__operator_matrix *op,
                                  const phks__lanczos_null *z, size_t k,
                                  const phks_options *opt, phks__lanczos_out *out)
{
    size_t n = op->n, zeros = z->count < k ? z->count : k, rest = k - zeros;
    size_t guard, cap;
    phks__lanczos_null_vectors(z, zeros, out->vectors, n);
    for (size_t e = 0; e < zeros; e++)
        out->values[e] = 0;
    /* more zeros than asked for: the k-th and the next are both 0 */
    out->next = z->count > k ? 0 : INFINITY;
    if (rest == 0)
        return PHKS_OK;
    if (!plan_sizes(n - z->count, k, rest, &guard, &cap))
        return PHKS_ERROR_NO_CONVERGENCE;
    phks__lanczos_out part = {out->values + zeros, out->vectors + zeros * n,
                              INFINITY, INFINITY};
    double lmax = 0, cut = 0, none = 0;
    eng->null = z;
    phks_status st = probe(eng, rest, (size_t)((double)(rest + guard) * CUT_MARGIN),
                           &lmax, &cut, &none);
    if (st == PHKS_OK)
        st = solve_probed(eng, rest, guard, cap, op->norm_bound, lmax, cut,
                          opt, &part);
    eng->null = NULL;
    out->next = part.next;
    return st;
}

/* The probe; then the null space deflated where the probe shows more
 * zeros than a block and the kernel's components confirm them, or else
 * the filtered solves. Values and vectors in the pair matrix's
 * numbering. */
static phks_status solve_all(phks__lanczos_engine *eng,
                             const phks__operator_matrix *op, size_t k,
                             size_t guard, size_t cap, const phks_options *opt,
                             phks__lanczos_out *out)
{
    double lmax = 0, cut = 0, zeros = 0;
    phks_status st = probe(eng, k, (size_t)((double)(k + guard) * CUT_MARGIN),
                           &lmax, &cut, &zeros);
    if (st != PHKS_OK)
        return st;
    if (zeros > BLOCK) {
        phks__lanczos_null z;
        st = phks__lanczos_null_build(op, eng->pm, &z);
        bool deflate = st == PHKS_OK && z.count > BLOCK;
        if (deflate)
            st = solve_deflated(eng, op, &z, k, opt, out);
        phks__lanczos_null_release(&z);
        if (st != PHKS_OK || deflate)
            return st;
    }
    return solve_probed(eng, k, guard, cap, op->norm_bound, lmax, cut, opt, out);
}

phks_status phks__eigen_lanczos(const phks__operator_matrix *op, size_t k,
                               const phks_options *opt, double *values,
                               double *vectors, double *next)
{
    size_t n = op->n, guard, cap;
    if (!plan_sizes(n, k, k, &guard, &cap))
        return phks__eigen_dense(op, k, opt, values, vectors, next);
    phks__operator_pairs pm;
    phks_status st = phks__operator_pairs_build(op, phks__thread_count(opt), &pm);
    if (st != PHKS_OK)
        return st;
    phks__lanczos_engine eng = {&pm, phks__cpu_avx2(), opt, 0, NULL};
    phks__lanczos_out out = {values, vectors, INFINITY, INFINITY};
    st = solve_all(&eng, op, k, guard, cap, opt, &out);
    if (next)
        *next = out.next;
    if (st == PHKS_OK) {
        /* back to the operator's numbering */
        double *column = phks__malloc_array(n, sizeof *column);
        if (!column)
            st = phks__fail_oom("Lanczos");
        for (size_t e = 0; e < k && st == PHKS_OK; e++) {
            double *x = vectors + e * n;
            memcpy(column, x, n * sizeof *column);
            for (size_t r = 0; r < n; r++)
                x[pm.order[r]] = column[r];
        }
        phks__free(column);
    }
    phks__operator_pairs_release(&pm);
    /* Not expected; the dense solver is exact where it fits. Where it
     * does not, ARPACK: much slower, but it deflates the null space too
     * and checks for missed copies of a multiple eigenvalue. */
    if (st == PHKS_ERROR_NO_CONVERGENCE && n <= DENSE_FALLBACK_MAX_N)
        return phks__eigen_dense(op, k, opt, values, vectors, next);
    if (st == PHKS_ERROR_NO_CONVERGENCE)
        return phks__eigen_arpack(op, k, opt, values, vectors, next);
    return st;
}
