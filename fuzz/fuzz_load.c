/*
 * fuzz_load.c - the public loader, phks_mesh_load_memory with
 * PHKS_FORMAT_AUTO: gzip recognition and inflation, format detection, the
 * four readers and the mesh builder, on any bytes.
 */
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_load(data, size, PHKS_FORMAT_AUTO);
    return 0;
}
