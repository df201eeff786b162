/*
 * simd.h - whether this build has the AVX2 + FMA kernels. They are
 * compiled with target attributes, whatever the build's own instruction
 * set, and chosen at run time by phks__cpu_avx2() (simd.c). PHKS_NO_SIMD (a
 * compiler flag) builds the portable kernels only, to test them on
 * machines that have AVX2.
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
