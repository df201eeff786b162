/*
 * load.c - from a file or a buffer to the arrays of a raw mesh: read the
 * bytes, inflate gzip, pick the reader by name or content. The geometry
 * layer (geometry/mesh_load.c) builds the cleaned mesh from them.
 */
#include "io/io.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <zlib.h>

/* phks.h promises that a gzip stream may inflate to 2 GiB and no more: a
 * few kilobytes of deflate data can expand a thousandfold, and we would
 * rather refuse than exhaust the host's memory. */
#ifndef PHKS_GZIP_LIMIT
#define PHKS_GZIP_LIMIT ((size_t)1 << 31)
#endif

/* Deflate never expands more than about 1032:1, which bounds how much of
 * the size a gzip trailer claims we trust before we have seen it. */
#define DEFLATE_MAX_RATIO 1032

void phks__raw_mesh_release(phks__raw_mesh *raw)
{
    if (!raw)
        return;
    phks__free(raw->xyz);
    phks__free(raw->triangles);
    phks__free(raw->vertex_origin);
    memset(raw, 0, sizeof *raw);
}

/* ------------------------------------------------------------------- file */

/* strerror is not thread-safe; the loader is documented to be. */
static phks_status io_fail(const char *what, int err)
{
    char text[128] = "unknown error";
#ifdef _WIN32
    strerror_s(text, sizeof text, err);
#else
    if (strerror_r(err, text, sizeof text) != 0)
        snprintf(text, sizeof text, "error %d", err);
#endif
    return phks__fail(PHKS_ERROR_IO, "%s: %s", what, text);
}

static phks_status read_stream(FILE *f, size_t hint, char **out, size_t *size)
{
    /* One byte more than the expected size lets the end be seen without
     * growing the buffer. */
    size_t cap = hint < SIZE_MAX - 1 ? hint + 1 : hint, len = 0;
    if (cap < 4096)
        cap = 4096;
    char *buf = phks__malloc(cap);
    if (!buf)
        return phks__fail_oom("file contents");
    for (;;) {
        len += fread(buf + len, 1, cap - len, f);
        if (len < cap)
            break;
        char *bigger = cap <= SIZE_MAX / 2 ? phks__realloc(buf, 2 * cap) : NULL;
        if (!bigger) {
            phks__free(buf);
            return phks__fail_oom("file contents");
        }
        buf = bigger;
        cap *= 2;
    }
    if (ferror(f)) {
        int err = errno;
        phks__free(buf);
        return io_fail("cannot read", err);
    }
    *out = buf;
    *size = len;
    return PHKS_OK;
}

static phks_status read_file(const char *path, char **out, size_t *size)
{
    errno = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return io_fail("cannot open", errno);
    struct stat st;
    size_t hint = 0;
    phks_status status = PHKS_OK;
    if (fstat(fileno(f), &st) == 0) {
        if (S_ISDIR(st.st_mode))
            status = io_fail("cannot read", EISDIR);
        else if (S_ISREG(st.st_mode) && st.st_size > 0)
            hint = (uint64_t)st.st_size < SIZE_MAX ? (size_t)st.st_size : SIZE_MAX;
    }
    if (status == PHKS_OK)
        status = read_stream(f, hint, out, size);
    fclose(f);
    return status;
}

/* ------------------------------------------------------------------- gzip */

static bool is_gzip(const unsigned char *data, size_t size)
{
    return size >= 2 && data[0] == 0x1f && data[1] == 0x8b;
}

/* zlib's own allocations go through the library's hook too. */
static voidpf zlib_alloc(voidpf user, uInt items, uInt size)
{
    (void)user;
    return phks__malloc_array(items, size);
}

static void zlib_free(voidpf user, voidpf ptr)
{
    (void)user;
    phks__free(ptr);
}

/* A first guess at the inflated size: the trailer's ISIZE (the size modulo
 * 2^32 of the last member), believed only as far as deflate could expand. */
static size_t inflated_guess(const unsigned char *in, size_t size,
                             size_t limit)
{
    size_t guess = 4 * size;
    if (size >= 18) {
        const unsigned char *t = in + size - 4;
        guess = (size_t)t[0] | (size_t)t[1] << 8 | (size_t)t[2] << 16 |
                (size_t)t[3] << 24;
    }
    size_t bound = size < limit / DEFLATE_MAX_RATIO
                       ? size * DEFLATE_MAX_RATIO + 64
                       : limit;
    if (guess > bound)
        guess = bound;
    return guess < 65536 ? 65536 : guess + 1;
}

static phks_status inflate_error(int ret, const z_stream *z, size_t offset)
{
    if (ret == Z_MEM_ERROR)
        return phks__fail_oom("gzip inflation");
    return phks__fail(PHKS_ERROR_PARSE, "gzip data: byte offset %zu: %s",
                     offset, z->msg ? z->msg : "invalid compressed data");
}

static phks_status inflates_past(size_t limit)
{
    return phks__fail(PHKS_ERROR_TOO_LARGE,
                      "gzip data inflates to more than %zu bytes", limit);
}

/* Runs inflate over every gzip member of in, into a buffer that grows by
 * doubling up to the limit plus one byte: reaching that byte means the
 * stream is too large. */
static phks_status inflate_all(z_stream *z, const unsigned char *in,
                               size_t size, size_t limit, char **out,
                               size_t *out_size)
{
    size_t cap = inflated_guess(in, size, limit), len = 0, used = 0;
    if (cap > limit + 1)
        cap = limit + 1;
    char *buf = phks__malloc(cap);
    if (!buf)
        return phks__fail_oom("gzip inflation");
    phks_status st = PHKS_OK;
    for (;;) {
        if (len == cap) {
            if (cap > limit) {
                st = inflates_past(limit);
                break;
            }
            size_t next = cap > limit / 2 ? limit + 1 : 2 * cap;
            char *bigger = phks__realloc(buf, next);
            if (!bigger) {
                st = phks__fail_oom("gzip inflation");
                break;
            }
            buf = bigger;
            cap = next;
        }
        size_t in_left = size - used, out_left = cap - len;
        z->next_in = (Bytef *)(uintptr_t)(in + used);
        z->avail_in = in_left < UINT_MAX ? (uInt)in_left : UINT_MAX;
        z->next_out = (Bytef *)buf + len;
        z->avail_out = out_left < UINT_MAX ? (uInt)out_left : UINT_MAX;
        size_t used_before = used, len_before = len;
        int ret = inflate(z, Z_NO_FLUSH);
        used = (size_t)(z->next_in - in);
        len = (size_t)((char *)z->next_out - buf);
        bool stuck = used == used_before && len == len_before;
        if (len > limit) { /* the byte past the limit, even if last */
            st = inflates_past(limit);
            break;
        }
        if (ret == Z_STREAM_END) {
            /* Concatenated members inflate to the concatenation, as with
             * gunzip; other trailing bytes (padding) are ignored. */
            if (!is_gzip(in + used, size - used))
                break;
            ret = inflateReset(z);
        }
        if (ret == Z_BUF_ERROR && stuck && z->avail_out > 0) {
            st = phks__fail(PHKS_ERROR_TRUNCATED,
                           "gzip data: byte offset %zu: the compressed data "
                           "ends early",
                           size);
            break;
        }
        if (ret != Z_OK && ret != Z_BUF_ERROR) {
            st = inflate_error(ret, z, used);
            break;
        }
    }
    if (st != PHKS_OK) {
        phks__free(buf);
        return st;
    }
    *out = buf;
    *out_size = len;
    return PHKS_OK;
}

static phks_status gunzip(const void *in, size_t size, size_t limit,
                          char **out, size_t *out_size)
{
    z_stream z;
    memset(&z, 0, sizeof z);
    z.zalloc = zlib_alloc;
    z.zfree = zlib_free;
    int ret = inflateInit2(&z, 15 + 32); /* 32: expect a gzip header */
    if (ret != Z_OK)
        return inflate_error(ret, &z, 0);
    phks_status st = inflate_all(&z, in, size, limit, out, out_size);
    inflateEnd(&z);
    return st;
}

/* ----------------------------------------------------------------- format */

static char lower(char c)
{
    return c >= 'A' && c <= 'Z' ? (char)(c - 'A' + 'a') : c;
}

static bool ends_with_nocase(const char *s, size_t n, const char *suffix)
{
    size_t k = strlen(suffix);
    if (n < k)
        return false;
    for (size_t i = 0; i < k; i++)
        if (lower(s[n - k + i]) != suffix[i])
            return false;
    return true;
}

static phks_format format_from_name(const char *path)
{
    size_t n = strlen(path);
    if (ends_with_nocase(path, n, ".gz"))
        n -= 3;
    static const struct {
        const char *ext;
        phks_format format;
    } names[] = {{".off", PHKS_FORMAT_OFF},
                 {".obj", PHKS_FORMAT_OBJ},
                 {".ply", PHKS_FORMAT_PLY},
                 {".stl", PHKS_FORMAT_STL}};
    for (size_t i = 0; i < sizeof names / sizeof *names; i++)
        if (ends_with_nocase(path, n, names[i].ext))
            return names[i].format;
    return PHKS_FORMAT_AUTO;
}

static bool is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' ||
           c == '\f';
}

/* The first word of the data after blanks and '#' comment lines. */
static size_t first_word(const char *d, size_t size, const char **word)
{
    size_t i = size >= 3 && memcmp(d, "\xEF\xBB\xBF", 3) == 0 ? 3 : 0;
    while (i < size && (is_space(d[i]) || d[i] == '#')) {
        if (d[i] == '#')
            while (i < size && d[i] != '\n')
                i++;
        else
            i++;
    }
    size_t start = i;
    while (i < size && !is_space(d[i]) && d[i] != '#')
        i++;
    *word = d + start;
    return i - start;
}

/* OFF, COFF, NOFF, STCNOFF, 4OFF...: the reader refuses what it cannot
 * read with a better message than "unknown format". */
static bool is_off_keyword(const char *w, size_t n)
{
    if (n < 3 || n > 9 || memcmp(w + n - 3, "OFF", 3) != 0)
        return false;
    for (size_t i = 0; i + 3 < n; i++)
        if (w[i] == '\0' || !strchr("STCN4n", w[i]))
            return false;
    return true;
}

/* An OBJ statement that only OBJ files have, at the start of a line within
 * the first 64 KiB. */
static bool looks_like_obj(const char *d, size_t size)
{
    size_t limit = size < 65536 ? size : 65536;
    for (size_t i = 0; i < limit;) {
        size_t j = i;
        while (j < limit && (d[j] == ' ' || d[j] == '\t'))
            j++;
        if (j + 1 < limit && (d[j] == 'v' || d[j] == 'f') &&
            (d[j + 1] == ' ' || d[j + 1] == '\t'))
            return true;
        const char *nl = memchr(d + j, '\n', limit - j);
        i = nl ? (size_t)(nl - d) + 1 : limit;
    }
    return false;
}

static phks_format sniff(const char *d, size_t size)
{
    if (size >= 4 && memcmp(d, "ply", 3) == 0 &&
        (d[3] == '\n' || (d[3] == '\r' && size >= 5 && d[4] == '\n')))
        return PHKS_FORMAT_PLY;
    const char *w;
    size_t n = first_word(d, size, &w);
    if (is_off_keyword(w, n))
        return PHKS_FORMAT_OFF;
    if (n == 5 && ends_with_nocase(w, n, "solid"))
        return PHKS_FORMAT_STL;
    if (size >= 84) {
        const unsigned char *c = (const unsigned char *)d + 80;
        uint32_t facets = (uint32_t)c[0] | (uint32_t)c[1] << 8 |
                          (uint32_t)c[2] << 16 | (uint32_t)c[3] << 24;
        if (84 + 50 * (uint64_t)facets == size)
            return PHKS_FORMAT_STL;
    }
    if (looks_like_obj(d, size))
        return PHKS_FORMAT_OBJ;
    return PHKS_FORMAT_AUTO;
}

/* ------------------------------------------------------------------- load */

/* Parses a whole uncompressed file held in memory. */
static phks_status parse(const char *data, size_t size, phks_format format,
                         phks__raw_mesh *raw)
{
    if (format == PHKS_FORMAT_AUTO)
        format = sniff(data, size);
    switch (format) {
    case PHKS_FORMAT_OFF: return phks__read_off(data, size, raw);
    case PHKS_FORMAT_OBJ: return phks__read_obj(data, size, raw);
    case PHKS_FORMAT_PLY: return phks__read_ply(data, size, raw);
    case PHKS_FORMAT_STL: return phks__read_stl(data, size, raw);
    case PHKS_FORMAT_AUTO:
    default:
        return phks__fail(PHKS_ERROR_UNKNOWN_FORMAT,
                         "not an OFF, OBJ, PLY or STL file");
    }
}

/* Inflates gzip data first, to at most max_bytes (and the built-in
 * PHKS_GZIP_LIMIT); plain data over max_bytes is refused unread. Takes
 * ownership of *owned when set, so the compressed bytes are freed before
 * the much larger parse begins. */
static phks_status load(const char *data, size_t size, char *owned,
                        phks_format format, size_t max_bytes,
                        phks__raw_mesh *raw)
{
    char *inflated = NULL;
    phks_status st = PHKS_OK;
    if (is_gzip((const unsigned char *)data, size)) {
        size_t limit = max_bytes < PHKS_GZIP_LIMIT ? max_bytes : PHKS_GZIP_LIMIT;
        st = gunzip(data, size, limit, &inflated, &size);
        phks__free(owned);
        owned = NULL;
        data = inflated;
    } else if (size > max_bytes) {
        st = phks__fail(PHKS_ERROR_TOO_LARGE,
                        "%zu bytes of mesh data, more than the limit of %zu",
                        size, max_bytes);
    }
    if (st == PHKS_OK)
        st = parse(data, size, format, raw);
    phks__free(inflated);
    phks__free(owned);
    return st;
}

phks_status phks__raw_mesh_read_file(const char *path, phks__raw_mesh *raw)
{
    char *data = NULL;
    size_t size = 0;
    phks_status st = read_file(path, &data, &size);
    if (st == PHKS_OK)
        st = load(data, size, data, format_from_name(path), SIZE_MAX, raw);
    return st;
}

phks_status phks__raw_mesh_read_memory(const void *data, size_t size,
                                      phks_format format, size_t max_bytes,
                                      phks__raw_mesh *raw)
{
    return load(data, size, NULL, format, max_bytes, raw);
}
