/*
 * fuzz_gzip.c - gzip input to phks_mesh_load_memory.
 *
 * Input that starts with the gzip magic bytes goes to the loader as it is:
 * damaged headers, deflate data, trailers, members and padding. Any other
 * input is a control byte and a payload: the payload is compressed here
 * into one or two gzip members (so their checksums are right and the
 * inflated bytes reach the readers) and then loaded:
 *   bits 0-3  deflate level (0..9; higher values mean 9)
 *   bit  4    split the payload into two members
 *   bits 5-7  where to split, in eighths of the payload
 */
#include "fuzz_common.h"

#include <zlib.h>

/* Appends one gzip member holding [p, p + n) to out at *len. */
static void put_member(unsigned char *out, size_t cap, size_t *len,
                       const unsigned char *p, size_t n, int level)
{
    z_stream z;
    memset(&z, 0, sizeof z);
    FUZZ_CHECK(deflateInit2(&z, level, Z_DEFLATED, 15 + 16, 8,
                            Z_DEFAULT_STRATEGY) == Z_OK);
    z.next_in = (Bytef *)(uintptr_t)p;
    z.avail_in = (uInt)n;
    z.next_out = out + *len;
    z.avail_out = (uInt)(cap - *len);
    FUZZ_CHECK(deflate(&z, Z_FINISH) == Z_STREAM_END);
    *len = cap - z.avail_out;
    deflateEnd(&z);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size >= 2 && data[0] == 0x1f && data[1] == 0x8b) {
        fuzz_load(data, size, PHKS_FORMAT_AUTO);
        return 0;
    }
    if (size == 0 || size > (1u << 24))
        return 0;
    unsigned control = data[0];
    int level = (int)(control & 15) > 9 ? 9 : (int)(control & 15);
    const unsigned char *payload = data + 1;
    size_t n = size - 1;
    size_t split = control & 16 ? n * (control >> 5) / 8 : n;

    size_t cap = 2 * (compressBound((uLong)n) + 64);
    unsigned char *gz = malloc(cap);
    FUZZ_CHECK(gz != NULL);
    size_t len = 0;
    put_member(gz, cap, &len, payload, split, level);
    if (split < n)
        put_member(gz, cap, &len, payload + split, n - split, level);
    fuzz_load(gz, len, PHKS_FORMAT_AUTO);
    free(gz);
    return 0;
}
