/*
 * cli_hash.c - a fixed 64-bit hash for generator seeds and cache keys: the
 * splitmix64 finaliser applied after every byte or word. Portable and
 * stable: the same input gives the same value on every machine.
 */
#include "common/cli_common.h"

#include <string.h>

uint64_t cli_mix64(uint64_t x)
{
    x += UINT64_C(0x9e3779b97f4a7c15);
    x = (x ^ (x >> 30)) * UINT64_C(0xbf58476d1ce4e5b9);
    x = (x ^ (x >> 27)) * UINT64_C(0x94d049bb133111eb);
    return x ^ (x >> 31);
}

uint64_t cli_hash_bytes(uint64_t h, const void *data, size_t size)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < size; i++)
        h = cli_mix64(h ^ p[i]);
    return h;
}

uint64_t cli_hash_u64(uint64_t h, uint64_t word)
{
    return cli_mix64(h ^ word);
}

uint64_t cli_hash_double(uint64_t h, double value)
{
    uint64_t bits;
    memcpy(&bits, &value, sizeof bits);
    return cli_hash_u64(h, bits);
}

uint64_t cli_hash_string(uint64_t h, const char *text)
{
    size_t n = strlen(text);
    return cli_hash_u64(cli_hash_bytes(h, text, n), n);
}
