/*
 * radix_sort.c - the stable LSD radix sort that ranks persistence's values
 * and edges and groups HKS-simp's vertices by cell: linear in the count,
 * where a comparison sort would be n log n on a million items.
 */
#include "core/core.h"

#include <string.h>

/* Passes over this many items or more report progress between them. */
#define REPORT_MIN ((size_t)1 << 18)

phks_status phks__radix_sort(phks__keyed *a, phks__keyed *tmp, size_t n,
                             unsigned bits, phks__span at, phks__keyed **sorted)
{
    enum { DIGIT = 11, BUCKETS = 1 << DIGIT };
    size_t count[BUCKETS];
    for (unsigned shift = 0; shift < bits && n > 0; shift += DIGIT) {
        if (n >= REPORT_MIN && shift > 0) {
            phks_status st = phks__span_report(at, (double)shift / bits);
            if (st != PHKS_OK)
                return st;
        }
        memset(count, 0, sizeof count);
        for (size_t i = 0; i < n; i++)
            count[(a[i].key >> shift) & (BUCKETS - 1)]++;
        if (count[(a[0].key >> shift) & (BUCKETS - 1)] == n)
            continue; /* one digit everywhere: nothing to move */
        size_t sum = 0;
        for (size_t d = 0; d < BUCKETS; d++) {
            size_t c = count[d];
            count[d] = sum;
            sum += c;
        }
        for (size_t i = 0; i < n; i++)
            tmp[count[(a[i].key >> shift) & (BUCKETS - 1)]++] = a[i];
        phks__keyed *s = a;
        a = tmp;
        tmp = s;
    }
    *sorted = a;
    return PHKS_OK;
}
