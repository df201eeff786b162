/*
 * simd.h - whether this build has the AVX2 + FMA kernels. They are
 * compiled with target attributes, whatever the build's own instruction
 * set, and chosen at run time by phks__cpu_avx2() (simd.c).
 *
 * PHKS_NO_SIMD (meson's -Dsimd=disabled defines it for every file) builds
 * the portable loops alone, to test them on machines that have SIMD. It
 * turns off every SIMD path of the library: the AVX2 + FMA kernels here
 * (operator, eigen, spectrum), the SSE2 loops of the verifier
 * (features/verify.c), and the vector lanes and AVX2 clones of the
 * nearest-L1 kernel (features/nearest_kernel.h: score.c, db_scan.c).
 * Scores are the same bits either way; signatures are not (FMA and the
 * fast exp of the kernels round otherwise).
 */
#ifndef PHKS_SIMD_H
#define PHKS_SIMD_H

#include <stdbool.h>

#if defined(__GNUC__) && defined(__x86_64__) && !defined(PHKS_NO_SIMD)
#include <immintrin.h>
#define PHKS__HAVE_AVX2 1
#else
#define PHKS__HAVE_AVX2 0
#endif

/* True when the AVX2 + FMA kernels are built and this processor runs
 * them. */
bool phks__cpu_avx2(void);

#endif
