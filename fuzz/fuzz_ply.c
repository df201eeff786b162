/*
 * fuzz_ply.c - the PLY reader (ascii and both binary encodings) on any
 * bytes, through the internal phks__read_ply (no format detection in the
 * way), then the mesh built from what it returns; both checked against
 * fuzz_common.h's invariants.
 */
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_reader(phks__read_ply, data, size);
    return 0;
}
