/*
 * funk_hecke.c - the sphere's eigenvalues of the mesh-Laplacian's kernel
 * by the Funk-Hecke formula (docs/method.md section 5), the oracle of
 * test_sphere.c and test_symmetric.c.
 */
#include "funk_hecke.h"
#include "testutil.h"

#include <math.h>

double gl_x[GL_NODES], gl_w[GL_NODES];

static double legendre(int l, double x)
{
    double p0 = 1, p1 = x;
    if (l == 0)
        return 1;
    for (int k = 1; k < l; k++) {
        double p2 = ((2 * k + 1) * x * p1 - k * p0) / (k + 1);
        p0 = p1;
        p1 = p2;
    }
    return p1;
}

/* Gauss-Legendre nodes by Newton's method on P_n. */
void gauss_legendre_init(void)
{
    const int n = GL_NODES;
    for (int i = 0; i < n; i++) {
        double x = cos(PI * (i + 0.75) / (n + 0.5));
        double dp = 1;
        for (int it = 0; it < 100; it++) {
            double p = legendre(n, x), pm = legendre(n - 1, x);
            dp = n * (x * p - pm) / (x * x - 1);
            double dx = p / dp;
            x -= dx;
            if (fabs(dx) < 1e-16)
                break;
        }
        double p = legendre(n, x), pm = legendre(n - 1, x);
        dp = n * (x * p - pm) / (x * x - 1);
        gl_x[i] = x;
        gl_w[i] = 2 / ((1 - x * x) * dp * dp);
    }
}

/* int_a^b f(u) du, f(u) = exp(-u / width) * (1 - P_l(1 - u)) */
static double panel(int l, double width, double a, double b)
{
    double sum = 0, half = (b - a) / 2, mid = (a + b) / 2;
    for (int i = 0; i < GL_NODES; i++) {
        double u = mid + half * gl_x[i];
        sum += gl_w[i] * exp(-u / width) * (1 - legendre(l, 1 - u));
    }
    return sum * half;
}

/* mu_l of a sphere of radius R for kernel parameter h, the kernel cut at
 * chord length r (r = INFINITY: no cut-off). */
double funk_hecke(int l, double R, double h, double r)
{
    double width = 2 * h / (R * R);
    double umax = fmin(2.0, r * r / (2 * R * R));
    double integral = 0, a = 0, b = width;
    while (a < umax) {
        b = fmin(b, umax);
        integral += panel(l, width, a, b);
        a = b;
        b = a < width ? width : 2 * a;
        if (a > 80 * width && umax == 2.0) { /* exp(-80): nothing left */
            integral += panel(l, width, a, 2.0);
            break;
        }
    }
    return R * R / (2 * h * h) * integral;
}
