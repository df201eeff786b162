/*
 * sym3_eigen.c - the symmetric 3 x 3 eigenproblem, for the principal axes
 * of the unit box (unit_box.c).
 */
#include "geometry/geometry.h"

#include <math.h>

/* Cyclic Jacobi: own code rather than LAPACK's dsyev, whose result (OpenBLAS 0.3.21,
 * even at 3 x 3) changes in the last bits with OPENBLAS_NUM_THREADS, and
 * with it the box and every number after it. A Jacobi rotation zeroes one off-diagonal entry
 * (Rutishauser's formulas, as in Numerical Recipes' jacobi); sweeps over
 * the three converge quadratically, and after four sweeps an entry too
 * small to change either diagonal entry it couples is set to zero, so the
 * loop ends with an exactly diagonal matrix (a million random matrices,
 * some nearly diagonal or nearly degenerate: at most five sweeps). Plain
 * arithmetic in a fixed order: the same bits on every run, and the same
 * eigenvectors for the matrix times any power of two. */

#define JACOBI_SWEEPS 60

/* Rotates rows/columns p and q of the symmetric a (and columns of v) to
 * zero a[p][q]. */
static void jacobi_rotate(double a[3][3], double v[3][3], int p, int q,
                          int sweep)
{
    double apq = a[p][q];
    if (apq == 0)
        return;
    double g = 100 * fabs(apq);
    if (sweep > 4 && fabs(a[p][p]) + g == fabs(a[p][p]) &&
        fabs(a[q][q]) + g == fabs(a[q][q])) {
        a[p][q] = a[q][p] = 0;
        return;
    }
    double h = a[q][q] - a[p][p], t;
    if (fabs(h) + g == fabs(h)) {
        t = apq / h; /* 1 / (2 theta), theta huge */
    } else {
        double theta = 0.5 * h / apq;
        t = 1 / (fabs(theta) + sqrt(1 + theta * theta));
        if (theta < 0)
            t = -t;
    }
    double c = 1 / sqrt(1 + t * t), s = t * c, tau = s / (1 + c);
    h = t * apq;
    a[p][p] -= h;
    a[q][q] += h;
    a[p][q] = a[q][p] = 0;
    int r = 3 - p - q; /* the third index */
    double arp = a[r][p], arq = a[r][q];
    a[r][p] = a[p][r] = arp - s * (arq + arp * tau);
    a[r][q] = a[q][r] = arq + s * (arp - arq * tau);
    for (int i = 0; i < 3; i++) {
        double vp = v[i][p], vq = v[i][q];
        v[i][p] = vp - s * (vq + vp * tau);
        v[i][q] = vq + s * (vp - vq * tau);
    }
}

void phks__sym3_eigen(const double matrix[9], double values[3],
                     double vectors[9])
{
    double a[3][3], v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int i = 0; i < 3; i++)
        for (int j = i; j < 3; j++)
            a[i][j] = a[j][i] = matrix[3 * i + j]; /* the upper triangle */
    for (int sweep = 1; sweep <= JACOBI_SWEEPS; sweep++) {
        if (a[0][1] == 0 && a[0][2] == 0 && a[1][2] == 0)
            break;
        jacobi_rotate(a, v, 0, 1, sweep);
        jacobi_rotate(a, v, 0, 2, sweep);
        jacobi_rotate(a, v, 1, 2, sweep);
    }
    /* Ascending, as dsyev (a stable order: ties keep their columns). */
    int order[3] = {0, 1, 2};
    for (int i = 1; i < 3; i++)
        for (int j = i; j > 0 && a[order[j]][order[j]] < a[order[j - 1]][order[j - 1]]; j--) {
            int x = order[j];
            order[j] = order[j - 1];
            order[j - 1] = x;
        }
    for (int j = 0; j < 3; j++) {
        int k = order[j], big = 0;
        values[j] = a[k][k];
        for (int i = 1; i < 3; i++)
            if (fabs(v[i][k]) > fabs(v[big][k]))
                big = i;
        double sign = v[big][k] < 0 ? -1 : 1;
        for (int i = 0; i < 3; i++)
            vectors[3 * i + j] = sign * v[i][k];
    }
}
