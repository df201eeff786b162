/* crc32.c - CRC-32 (the zlib/PNG polynomial) through zlib, which the
 * library links for .gz input anyway. zlib takes a uInt length, so long
 * buffers go in pieces. */
#include "core/core.h"

#include <zlib.h>

uint32_t phks__crc32(const void *data, size_t size)
{
    const unsigned char *p = data;
    uLong crc = crc32(0L, Z_NULL, 0);
    while (size > 0) {
        uInt piece = size > 0x40000000u ? 0x40000000u : (uInt)size;
        crc = crc32(crc, p, piece);
        p += piece;
        size -= piece;
    }
    return (uint32_t)crc;
}
