/*
 * random.c - the fixed generator behind the solvers' start vectors (a
 * 64-bit linear congruential generator, top 53 bits). ARPACK's own start
 * vector comes from a seed that carries over between calls; this one does
 * not, so every solve starts alike.
 */
#include "core/core.h"

void phks__random_fill(double *v, size_t n, uint64_t state)
{
    for (size_t i = 0; i < n; i++) {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        v[i] = (double)(state >> 11) * 0x1.0p-53 - 0.5;
    }
}
