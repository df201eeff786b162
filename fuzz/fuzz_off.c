/*
 * fuzz_off.c - the Geomview OFF reader on any bytes, through the internal
 * phks__read_off (no format detection in the way), then the mesh built from
 * what it returns; both checked against fuzz_common.h's invariants.
 */
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_reader(phks__read_off, data, size);
    return 0;
}
