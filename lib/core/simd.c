/*
 * simd.c - the run-time choice between the AVX2 + FMA kernels and the
 * portable ones (simd.h).
 */
#include "core/simd.h"

bool phks__cpu_avx2(void)
{
#if PHKS__HAVE_AVX2
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
    return false;
#endif
}
