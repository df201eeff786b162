/*
 * simp.h - HKS-simp, the path for large meshes (paper section 4.1 and
 * appendix B, docs/method.md section 11): declarations shared by
 * simp_sample.c (the samples), simp_extend.c (back to every
 * vertex) and spectrum.c, which strings them together with the operator
 * of laplacian.c:
 *
 *   mesh (n vertices) --simplify--> about simplify_target samples, each a
 *   mesh vertex carrying the area of the vertices nearest to it
 *   --point operator--> B on the samples --solver--> eigenpairs
 *   --Nystrom extension--> HKS at any vertex, computed when asked for.
 *
 * Nothing here holds an n x eigen_count array: the samples' eigenvectors
 * (samples x eigen_count) and O(n) arrays are all that is kept, so memory
 * grows only linearly with the vertex count (docs/benchmarks.md has the
 * memory measured on large meshes).
 */
#ifndef PHKS_SIMP_H
#define PHKS_SIMP_H

#include "spectrum/spectrum.h"

#include <math.h>
#include <string.h>

/* True when a mesh of n vertices goes through HKS-simp under opt. */
bool phks__simplify_applies(const phks_options *opt, size_t n);

/* ---- samples (simp_sample.c) */
typedef struct phks__samples {
    size_t count;
    uint32_t *vertex;    /* count mesh vertices, ascending                 */
    double *area;        /* count: the area each sample stands for (unit-
                            box units; sums to the mesh's): its Voronoi
                            area, adjusted to the mesh's kernel density */
    uint32_t *of_vertex; /* n: the sample nearest to each mesh vertex      */
    double *gain;        /* count: the kernel gain g_p of each sample (the
                            operator's K_pq is multiplied by
                            sqrt(g_p g_q))                                  */
} phks__samples;

/* Chooses about opt->simplify_target samples of mesh (positions scaled by
 * scale, vertex_area as phks__vertex_areas gives). Progress is reported in
 * PHKS_STAGE_OPERATOR from `done` to done + span. */
phks_status phks__simplify(const phks__unit_mesh *um, const phks_options *opt,
                           phks__span at, phks__samples *out);
void phks__samples_release(phks__samples *samples);

/* Points with masses and the kernel they are summed with: W(p, q) =
 * exp(-|p - q|^2 / (4 h)), cut off at `radius`. */
typedef struct phks__kernel_points {
    const double *xyz;  /* 3 per point */
    const double *area; /* the masses  */
    size_t n;
    double h, radius;
} phks__kernel_points;

/* The short-time heat diagonal of appendix B on a weighted point set: for
 * point i, (H^2)_ii / A_i with H = I - tau D^-1 L the one-step heat
 * operator of the points (xyz, 3 per point, unit-box units; area A). Kept
 * separate so tests can check it against a dense H. Points within radius
 * interact. */
phks_status phks__heat_diagonal(const phks__kernel_points *points,
                                const phks_options *opt, phks__span at,
                                double *out);

/* ---- extension to every vertex (simp_extend.c) */
struct phks__extension {
    size_t m;             /* samples                                        */
    uint32_t *vertex;     /* m: mesh vertex of each sample                  */
    double *area;         /* m: gathered areas A_p, the Nystrom weights     */
    double *root_gain;    /* m: sqrt(g_p), the samples' kernel gains        */
    double *mass;         /* m: Mh of the samples, under which the
                             spectrum's eigenvectors are orthonormal        */
    double *sample_xyz;   /* 3m unit-box positions                          */
    double *vertex_xyz;   /* 3n unit-box positions of the mesh's vertices   */
    double *rows;         /* m x count, eigenvectors sample-major           */
    phks__grid grid;       /* over sample_xyz, cells at least `radius`       */
    double h, radius;     /* kernel parameter and cut-off radius            */
    double total_area;    /* of the mesh, unit-box units                    */
    bool random_walk;     /* operator kind (changes the denominator)        */
};

/* Takes ownership of samples->vertex, area and gain (set to NULL) and
 * of mass (m entries); keeps copies of the positions and a sample-major
 * copy of spec->vectors (spec->count and the m x count vectors set).
 * On failure everything handed over is freed. */
phks_status phks__extension_create(phks_spectrum *spec,
                                   const phks__unit_mesh *um,
                                   phks__samples *samples, double *mass);
void phks__extension_free(struct phks__extension *ext);

/* HKS_t at mesh vertex v through the extension, in double precision. */
double phks__extend_hks_at(const phks_spectrum *spec, double t, size_t v);
/* HKS_t at every mesh vertex into out (n values), on `threads` workers,
 * reporting PHKS_STAGE_HKS progress through opt when opt is not NULL. */
phks_status phks__extend_hks(const phks_spectrum *spec, double t,
                            const phks_options *opt, unsigned threads,
                            double *out);

/* ---- shared helpers (simp_sample.c) */
/* e[j] = exp(-d2_j / 4h) (inv4h = 1 / 4h) where the squared distance d2_j
 * from p to point j (x[j], y[j], z[j]) is below r2, else 0; d2 receives the
 * d2_j. Vectorised (AVX2 where the CPU has it, the same bits
 * either way). */
void phks__kernel_row(const double *x, const double *y, const double *z,
                     size_t count, const double p[3], double r2, double inv4h,
                     double *e, double *d2);

/* ---- shared numerics */
/* exp(-x) for 0 <= x <= 700 to about 1e-11 relative, without branches, so
 * that loops over arrays of x vectorise. For the kernel weights of the
 * sampling and the extension, where libm's exp would be a third of the
 * run time; the samples' operator itself uses libm. */
static inline double phks__exp_neg(double x)
{
    /* 2^y with y = -x log2(e): y = k + f, |f| <= 1/2, by adding and taking
     * away 1.5 * 2^52 (round to nearest); 2^k from the exponent bits. */
    const double shift = 6755399441055744.0; /* 1.5 * 2^52 */
    double y = -x * 1.4426950408889634;
    double t = y + shift;
    double k = t - shift;
    double z = (y - k) * 0.6931471805599453; /* |z| <= ln(2) / 2 */
    uint64_t bits;
    memcpy(&bits, &t, sizeof bits);
    /* t and the shift share their exponent: the mantissas differ by k. */
    uint64_t e = (bits - 0x4338000000000000u + 1023u) << 52;
    double scale;
    memcpy(&scale, &e, sizeof scale);
    /* e^z by its Taylor polynomial of degree 9 (remainder < 2e-11). */
    double p = 1 + z * (1 + z * (0.5 + z * (1.0 / 6 + z * (1.0 / 24 +
               z * (1.0 / 120 + z * (1.0 / 720 + z * (1.0 / 5040 +
               z * (1.0 / 40320 + z * (1.0 / 362880)))))))));
    return p * scale;
}

#endif /* PHKS_SIMP_H */
