/*
 * funk_hecke.h - the Funk-Hecke oracle shared by the sphere tests
 * (funk_hecke.c).
 */
#ifndef PHKS_TEST_FUNK_HECKE_H
#define PHKS_TEST_FUNK_HECKE_H

/* Gauss-Legendre nodes and weights on [-1, 1], set by gauss_legendre_init
 * (call it before funk_hecke; calling it again is harmless). */
#define GL_NODES 32
extern double gl_x[GL_NODES], gl_w[GL_NODES];
void gauss_legendre_init(void);

/* mu_l of a sphere of radius R for kernel parameter h, the kernel cut at
 * chord length r (r = INFINITY: no cut-off). */
double funk_hecke(int l, double R, double h, double r);

#endif
