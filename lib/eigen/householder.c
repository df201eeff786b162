/*
 * householder.c - Householder QR of a tall, narrow block and the
 * tridiagonal reduction of a dense symmetric matrix, summed in a fixed
 * order (householder.h tells why).
 */
#include "eigen/householder.h"

#include <math.h>
#include <string.h>

/* x^T y in four interleaved partial sums, added in a fixed order: the
 * same bits on every run, and independent sums the compiler can keep in
 * vector registers. */
double phks__dot(const double *x, const double *y, size_t n)
{
    double s[4] = {0, 0, 0, 0};
    size_t i = 0;
    for (; i + 4 <= n; i += 4)
        for (size_t l = 0; l < 4; l++)
            s[l] += x[i + l] * y[i + l];
    for (; i < n; i++)
        s[0] += x[i] * y[i];
    return (s[0] + s[1]) + (s[2] + s[3]);
}

/* LAPACK's dlarfg: the reflector H = I - tau v v^T, v = (x / (alpha -
 * beta), 1), that maps (x, alpha) to (0, beta). x becomes v's other
 * entries, *alpha becomes beta; returns tau (0: H = I, x unchanged). The
 * squared norm of x is summed as it is: the vectors here are far from
 * overflow, and the sum is several times faster than a scaled one. */
static double reflector(double *alpha, double *x, size_t len)
{
    double xnorm = sqrt(phks__dot(x, x, len));
    if (xnorm == 0)
        return 0;
    double beta = -copysign(hypot(*alpha, xnorm), *alpha);
    double tau = (beta - *alpha) / beta, scale = 1 / (*alpha - beta);
    for (size_t i = 0; i < len; i++)
        x[i] *= scale;
    *alpha = beta;
    return tau;
}

/* (c_tail, *c_unit) := H (c_tail, *c_unit) for the reflector of tau whose
 * vector is (tail, 1) over the same entries. */
static void reflect(double tau, const double *tail, size_t len, double *c_tail,
                    double *c_unit)
{
    double s = tau * (*c_unit + phks__dot(tail, c_tail, len));
    *c_unit -= s;
    for (size_t i = 0; i < len; i++)
        c_tail[i] -= s * tail[i];
}

/* dgeqr2, then dorg2r: H(j) zeroes column j below its diagonal, its
 * vector (1 at row j) kept there; Q = H(0) ... H(b-1) times the first b
 * columns of the identity is built from the last reflector back, in
 * place. */
void phks__householder_qr(double *a, size_t n, size_t b, double *r,
                          double *tau)
{
    for (size_t j = 0; j < b; j++) {
        double *col = a + j * n;
        tau[j] = reflector(col + j, col + j + 1, n - j - 1);
        for (size_t c = j + 1; c < b; c++)
            reflect(tau[j], col + j + 1, n - j - 1, a + c * n + j + 1,
                    a + c * n + j);
    }
    if (r)
        for (size_t j = 0; j < b; j++)
            for (size_t i = 0; i < b; i++)
                r[j * b + i] = i <= j ? a[j * n + i] : 0;
    for (size_t j = b; j-- > 0;) {
        double *col = a + j * n;
        for (size_t c = j + 1; c < b; c++)
            reflect(tau[j], col + j + 1, n - j - 1, a + c * n + j + 1,
                    a + c * n + j);
        for (size_t i = j + 1; i < n; i++)
            col[i] *= -tau[j];
        col[j] = 1 - tau[j];
        memset(col, 0, j * sizeof *col);
    }
}

/* a[0:s, 0:s] := H a[0:s, 0:s] H for the reflector of tau with vector v
 * (s entries): with p = tau a v and w = p - (tau / 2) (p^T v) v, that is
 * a - v w^T - w v^T (dsytd2). Both triangles are kept, so that the product
 * runs down whole columns; the update leaves them bitwise symmetric (the
 * two products of an entry and of its mirror are the same, added in
 * either order). */
static void reflect_both_sides(double *a, size_t m, size_t s, const double *v,
                               double tau, double *w)
{
    for (size_t j = 0; j < s; j++)
        w[j] = tau * phks__dot(a + j * m, v, s);
    double alpha = -0.5 * tau * phks__dot(w, v, s);
    for (size_t l = 0; l < s; l++)
        w[l] += alpha * v[l];
    for (size_t j = 0; j < s; j++) {
        double *col = a + j * m;
        for (size_t l = 0; l < s; l++)
            col[l] -= v[l] * w[j] + w[l] * v[j];
    }
}

/* dsytd2 with UPLO = 'U': H(i), from the last column back, zeroes column
 * i + 1 above its superdiagonal. */
void phks__tridiagonal_reduce(double *a, size_t m, double *diag, double *off,
                              double *tau, double *work)
{
    if (m == 0)
        return;
    tau[m - 1] = 0;
    for (size_t i = m - 1; i-- > 0;) {
        double *col = a + (i + 1) * m;
        tau[i] = reflector(col + i, col, i);
        off[i] = col[i];
        if (tau[i] != 0) {
            col[i] = 1;
            reflect_both_sides(a, m, i + 1, col, tau[i], work);
            col[i] = off[i];
        }
        diag[i + 1] = a[(i + 1) * m + i + 1];
    }
    diag[0] = a[0];
}

/* dormtr: Q = H(m-2) ... H(0), so Q c applies H(0) first and Q^T c
 * H(m-2) first. */
void phks__tridiagonal_apply(const double *a, size_t m, const double *tau,
                             bool transpose, double *c, size_t cols)
{
    for (size_t j = 0; j < cols; j++) {
        double *x = c + j * m;
        for (size_t step = 0; step + 1 < m; step++) {
            size_t i = transpose ? m - 2 - step : step;
            if (tau[i] != 0)
                reflect(tau[i], a + (i + 1) * m, i, x, x + i);
        }
    }
}
