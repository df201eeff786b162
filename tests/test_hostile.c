/*
 * test_hostile.c - inputs made to hurt, through the public loader and
 * mesh constructors: non-finite and extreme coordinates, meshes without
 * area, counts and indices at the limits of their types, damaged gzip
 * data, a gzip bomb, and damaged signature blobs. Each must end in an
 * error status with a message (or, where the data is valid, a sane mesh),
 * without allocating what the input merely claims.
 * test_readers.c covers each reader's own errors; this file holds what it
 * does not.
 *
 * Built a second time with a small PHKS_GZIP_LIMIT compiled into its own
 * copy of mesh_load.c (tests/meson.build), where only the gzip_limit case
 * runs: the real limit, 2 GiB, is too much to inflate in a test.
 */
#include "testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>
#include <zlib.h>

/* ------------------------------------------------------------- helpers */

/* An allocator that remembers the largest single request. */
static size_t largest_request;

static void *probe_malloc(void *user, size_t size)
{
    (void)user;
    if (size > largest_request)
        largest_request = size;
    return malloc(size);
}

static void *probe_realloc(void *user, void *ptr, size_t size)
{
    (void)user;
    if (size > largest_request)
        largest_request = size;
    return realloc(ptr, size);
}

static void probe_free(void *user, void *ptr)
{
    (void)user;
    free(ptr);
}

static void probe_start(void)
{
    static const phks_allocator probe = {probe_malloc, probe_realloc,
                                         probe_free, NULL};
    largest_request = 0;
    ck_assert_int_eq(phks_set_allocator(&probe), PHKS_OK);
}

static size_t probe_stop(void)
{
    phks_set_allocator(NULL);
    return largest_request;
}

/* An allocator that counts the bytes the library holds and their peak
 * (and, as the probe, the largest request): each block carries its size
 * in a header. Every block must be freed before meter_stop(), as the
 * header is foreign to free(). */
#define METER_HEADER 16 /* keeps malloc's alignment */
static size_t meter_live, meter_peak;

static void *meter_keep(unsigned char *base, size_t size)
{
    if (size > largest_request)
        largest_request = size;
    memcpy(base, &size, sizeof size);
    meter_live += size;
    if (meter_live > meter_peak)
        meter_peak = meter_live;
    return base + METER_HEADER;
}

static size_t meter_size(void *ptr)
{
    size_t size;
    memcpy(&size, (unsigned char *)ptr - METER_HEADER, sizeof size);
    return size;
}

static void *meter_malloc(void *user, size_t size)
{
    (void)user;
    unsigned char *base =
        size <= SIZE_MAX - METER_HEADER ? malloc(size + METER_HEADER) : NULL;
    return base ? meter_keep(base, size) : NULL;
}

/* phks__realloc passes NULL on to malloc_fn: ptr is a block of ours. */
static void *meter_realloc(void *user, void *ptr, size_t size)
{
    (void)user;
    size_t old = meter_size(ptr);
    unsigned char *base =
        size <= SIZE_MAX - METER_HEADER
            ? realloc((unsigned char *)ptr - METER_HEADER, size + METER_HEADER)
            : NULL;
    if (!base)
        return NULL;
    meter_live -= old;
    return meter_keep(base, size);
}

static void meter_free(void *user, void *ptr)
{
    (void)user;
    if (!ptr)
        return;
    meter_live -= meter_size(ptr);
    free((unsigned char *)ptr - METER_HEADER);
}

static void meter_start(void)
{
    static const phks_allocator meter = {meter_malloc, meter_realloc,
                                         meter_free, NULL};
    meter_live = meter_peak = largest_request = 0;
    ck_assert_int_eq(phks_set_allocator(&meter), PHKS_OK);
}

/* What loading gzip data holds beside the inflated bytes: zlib's state
 * (7 KiB) and window (32 KiB), and the readers' first small buffers. */
#define GZIP_OVERHEAD ((size_t)64 << 10)

/* The peak; fails if a block is still held. */
static size_t meter_stop(void)
{
    phks_set_allocator(NULL);
    ck_assert_uint_eq(meter_live, 0);
    return meter_peak;
}

/* Loads an exact-size heap copy of data; on failure checks that no mesh
 * came out and that the message says something. */
static phks_status load(const void *data, size_t size, phks_format format,
                        phks_mesh **mesh)
{
    void *copy = malloc(size ? size : 1);
    ck_assert_ptr_nonnull(copy);
    memcpy(copy, data, size);
    *mesh = (phks_mesh *)copy; /* must be overwritten */
    phks_status st = phks_mesh_load_memory(copy, size, format, mesh);
    free(copy);
    if (st != PHKS_OK) {
        ck_assert_ptr_null(*mesh);
        ck_assert_msg(phks_last_error_message()[0] != '\0',
                      "status %d without a message", (int)st);
    } else {
        ck_assert_ptr_nonnull(*mesh);
    }
    return st;
}

static void expect_load_fail(const char *what, const void *data, size_t size,
                             phks_format format, phks_status want,
                             const char *needle)
{
    phks_mesh *mesh;
    phks_status st = load(data, size, format, &mesh);
    phks_mesh_free(st == PHKS_OK ? mesh : NULL);
    const char *m = phks_last_error_message();
    ck_assert_msg(st == want, "%s: status %d (%s), wanted %d; message \"%s\"",
                  what, (int)st, phks_status_string(st), (int)want, m);
    ck_assert_msg(strstr(m, needle) != NULL, "%s: message \"%s\" lacks \"%s\"",
                  what, m, needle);
}

/* gzip of `zeros` zero bytes, compressed a chunk at a time. */
static bytes gzip_zeros(size_t zeros)
{
    static const unsigned char chunk[1 << 16];
    z_stream z;
    memset(&z, 0, sizeof z);
    ck_assert_int_eq(deflateInit2(&z, 1, Z_DEFLATED, 15 + 16, 8,
                                  Z_DEFAULT_STRATEGY),
                     Z_OK);
    bytes b = {0};
    b.cap = zeros / 128 + 4096; /* zeros deflate 200:1 or more */
    b.p = malloc(b.cap);
    ck_assert_ptr_nonnull(b.p);
    size_t left = zeros;
    int ret;
    do {
        size_t n = left < sizeof chunk ? left : sizeof chunk;
        left -= n;
        z.next_in = (Bytef *)(uintptr_t)chunk;
        z.avail_in = (uInt)n;
        do {
            if (b.n == b.cap) {
                b.cap *= 2;
                b.p = realloc(b.p, b.cap);
                ck_assert_ptr_nonnull(b.p);
            }
            z.next_out = b.p + b.n;
            z.avail_out = (uInt)(b.cap - b.n);
            ret = deflate(&z, left ? Z_NO_FLUSH : Z_FINISH);
            ck_assert_int_ne(ret, Z_STREAM_ERROR);
            b.n = b.cap - z.avail_out;
        } while (z.avail_out == 0);
    } while (left > 0 || ret != Z_STREAM_END);
    deflateEnd(&z);
    return b;
}

static long max_rss_kib(void)
{
    struct rusage ru;
    ck_assert_int_eq(getrusage(RUSAGE_SELF, &ru), 0);
    return ru.ru_maxrss;
}

#ifndef PHKS_GZIP_LIMIT

/* CPU seconds of this process, for the figures gzip_bomb prints (no test
 * asserts a time: the machines are shared). */
static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void put_u32(bytes *b, uint32_t v, bool big)
{
    unsigned char c[4];
    for (int i = 0; i < 4; i++)
        c[big ? 3 - i : i] = (unsigned char)(v >> (8 * i));
    put(b, c, 4);
}

static void put_f32(bytes *b, float f, bool big)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    put_u32(b, u, big);
}

static void put_text(bytes *b, const char *s)
{
    put(b, s, strlen(s));
}

static void put_f64le(bytes *b, double d)
{
    uint64_t u;
    memcpy(&u, &d, 8);
    put_u32(b, (uint32_t)u, false);
    put_u32(b, (uint32_t)(u >> 32), false);
}

/* Pads b with `fill` to exactly n bytes. */
static void pad_to(bytes *b, size_t n, char fill)
{
    ck_assert_uint_le(b->n, n);
    while (b->n < n)
        put(b, &fill, 1);
}

/* A binary STL of `facets` facets, the corners given (9 floats each). */
static bytes binary_stl(const float *corners, uint32_t facets)
{
    bytes b = {0};
    char header[80] = "binary";
    put(&b, header, 80);
    put_u32(&b, facets, false);
    for (uint32_t f = 0; f < facets; f++) {
        for (int k = 0; k < 3; k++)
            put_f32(&b, 0, false);
        for (int k = 0; k < 9; k++)
            put_f32(&b, corners[9 * f + k], false);
        put(&b, "\0\0", 2);
    }
    return b;
}

/* gzip of data in one member, with zlib. */
static bytes gzip_of(const void *data, size_t n, int level)
{
    z_stream z;
    memset(&z, 0, sizeof z);
    ck_assert_int_eq(deflateInit2(&z, level, Z_DEFLATED, 15 + 16, 8,
                                  Z_DEFAULT_STRATEGY),
                     Z_OK);
    bytes b = {0};
    b.cap = deflateBound(&z, (uLong)n) + 64;
    b.p = malloc(b.cap);
    ck_assert_ptr_nonnull(b.p);
    z.next_in = (Bytef *)(uintptr_t)data;
    z.avail_in = (uInt)n;
    z.next_out = b.p;
    z.avail_out = (uInt)b.cap;
    ck_assert_int_eq(deflate(&z, Z_FINISH), Z_STREAM_END);
    b.n = b.cap - z.avail_out;
    deflateEnd(&z);
    return b;
}

/* ------------------------------------------------------------- numbers */

START_TEST(non_finite_coordinates)
{
    static const struct {
        const char *what, *text;
        const char *needle;
    } texts[] = {
        {"OBJ inf", "v 0 0 0\nv 1 0 0\nv 0 1 inf\nf 1 2 3\n", "line 3"},
        {"OBJ overflow", "v 0 0 0\nv 1e309 0 0\nv 0 1 0\nf 1 2 3\n", "line 2"},
        {"OFF nan(...)", "OFF\n3 1 0\n0 0 0\n1 0 0\nnan(0x7ff) 1 0\n3 0 1 2\n",
         "line 5"},
        {"OFF MSVC", "OFF\n3 1 0\n0 0 0\n-1.#IND 0 0\n0 1 0\n3 0 1 2\n",
         "line 4"},
        {"STL -Infinity",
         "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
         "vertex 1 -Infinity 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid s\n",
         "line 5"},
        {"PLY ascii 1e400",
         "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
         "property float y\nproperty float z\nelement face 1\n"
         "property list uchar int vertex_indices\nend_header\n"
         "0 0 0\n1 0 0\n0 1e400 0\n3 0 1 2\n",
         "line 12"},
    };
    for (size_t i = 0; i < sizeof texts / sizeof *texts; i++)
        expect_load_fail(texts[i].what, texts[i].text, strlen(texts[i].text),
                         PHKS_FORMAT_AUTO, PHKS_ERROR_NON_FINITE,
                         texts[i].needle);

    /* binary: a double +inf (little-endian) and a float NaN (big-endian) */
    for (int big = 0; big <= 1; big++) {
        bytes b = {0};
        put_text(&b, big ? "ply\nformat binary_big_endian 1.0\n"
                         : "ply\nformat binary_little_endian 1.0\n");
        put_text(&b, big ? "element vertex 3\nproperty float x\n"
                           "property float y\nproperty float z\n"
                         : "element vertex 3\nproperty double x\n"
                           "property double y\nproperty double z\n");
        put_text(&b, "element face 1\nproperty list uchar uint vertex_indices\n"
                     "end_header\n");
        for (int k = 0; k < 9; k++) {
            double v = k == 7 ? (big ? NAN : INFINITY) : k == 3 || k == 7;
            if (big)
                put_f32(&b, (float)v, true);
            else
                put_f64le(&b, v);
        }
        put(&b, "\3", 1);
        for (uint32_t k = 0; k < 3; k++)
            put_u32(&b, k, big);
        expect_load_fail(big ? "PLY BE NaN" : "PLY LE inf", b.p, b.n,
                         PHKS_FORMAT_AUTO, PHKS_ERROR_NON_FINITE, "byte offset");
        free(b.p);
    }
    const float nan_corner[9] = {0, 0, 0, 1, 0, 0, 0, NAN, 0};
    bytes b = binary_stl(nan_corner, 1);
    expect_load_fail("STL NaN", b.p, b.n, PHKS_FORMAT_AUTO,
                     PHKS_ERROR_NON_FINITE, "byte offset 124");
    free(b.p);

    /* the constructors */
    const float xyz_f[9] = {0, 0, 0, 1, 0, 0, 0, 1, NAN};
    const double xyz_d[9] = {0, 0, 0, 1, 0, 0, 0, -INFINITY, 0};
    const uint32_t tri[3] = {0, 1, 2};
    phks_mesh *mesh = (phks_mesh *)&b;
    ck_assert_int_eq(phks_mesh_create_f(xyz_f, 3, tri, 1, &mesh),
                     PHKS_ERROR_NON_FINITE);
    ck_assert_ptr_null(mesh);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "vertex 2"));
    ck_assert_int_eq(phks_mesh_create(xyz_d, 3, tri, 1, &mesh),
                     PHKS_ERROR_NON_FINITE);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "vertex 2"));
}
END_TEST

/* Regression: areas were computed with fourth powers of the coordinates,
 * so a triangle at 1e100 had an infinite area (and was accepted) and one
 * at 1e-100 a zero area (and was refused as degenerate); at 1e160 the
 * squared bounding box overflowed and every triangle was called
 * degenerate. Any finite mesh now gets its true area, or TOO_LARGE when
 * that area is beyond a double. */
START_TEST(extreme_finite_coordinates)
{
    static const double scales[] = {1e-150, 1e-100, 1e-60, 1, 1e60, 1e100,
                                    1e150};
    const uint32_t tri[6] = {0, 1, 2, 0, 2, 3};
    for (size_t i = 0; i < sizeof scales / sizeof *scales; i++) {
        double s = scales[i];
        double xyz[12] = {0, 0, 0, s, 0, 0, s, s, 0, 0, s, s};
        phks_mesh *mesh;
        phks_status st = phks_mesh_create(xyz, 4, tri, 2, &mesh);
        ck_assert_msg(st == PHKS_OK, "scale %g: %s", s, phks_last_error_message());
        double want = 0.5 * s * s * (1 + sqrt(3));
        double area = phks_mesh_area(mesh);
        ck_assert_msg(isfinite(area) && fabs(area - want) <= 1e-14 * want,
                      "scale %g: area %.17g, wanted %.17g", s, area, want);
        phks_mesh_free(mesh);
    }
    /* through a reader too */
    static const char big_obj[] =
        "v 0 0 0\nv 3e120 0 0\nv 0 4e120 0\nf 1 2 3\n";
    phks_mesh *mesh;
    ck_assert_int_eq(load(big_obj, strlen(big_obj), PHKS_FORMAT_AUTO, &mesh),
                     PHKS_OK);
    ck_assert_double_eq_tol(phks_mesh_area(mesh), 6e240, 1e227);
    phks_mesh_free(mesh);

    /* areas beyond a double, and a span beyond a double */
    const double huge[9] = {0, 0, 0, 1e200, 0, 0, 0, 1e200, 0};
    const double span[9] = {-1e308, 0, 0, 1e308, 0, 0, 0, 1, 0};
    const uint32_t one[3] = {0, 1, 2};
    ck_assert_int_eq(phks_mesh_create(huge, 3, one, 1, &mesh), PHKS_ERROR_TOO_LARGE);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "area"));
    ck_assert_int_eq(phks_mesh_create(span, 3, one, 1, &mesh), PHKS_ERROR_TOO_LARGE);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "span"));
}
END_TEST

/* The robust area is the plain formula's, bit for bit, at ordinary
 * scales: no mesh changes because of the fix above. */
START_TEST(triangle_area_is_unchanged_at_ordinary_scales)
{
    uint64_t state = 11;
    size_t differ = 0;
    for (int i = 0; i < 100000; i++) {
        double p[9];
        double scale = pow(10, 120 * test_random(&state) - 60);
        for (int k = 0; k < 9; k++)
            p[k] = (test_random(&state) - 0.5) * scale;
        double u[3] = {p[3] - p[0], p[4] - p[1], p[5] - p[2]};
        double v[3] = {p[6] - p[0], p[7] - p[1], p[8] - p[2]};
        double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                       u[0] * v[1] - u[1] * v[0]};
        double plain = 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        double got = phks__triangle_area(p, p + 3, p + 6);
        differ += memcmp(&plain, &got, sizeof got) != 0;
    }
    ck_assert_uint_eq(differ, 0);
}
END_TEST

/* ---------------------------------------------------------- zero area */

START_TEST(meshes_without_area)
{
    /* a pentagon on a line, fanned into three collinear triangles */
    static const char line_obj[] =
        "v 0 0 0\nv 1 1 1\nv 2 2 2\nv 3 3 3\nv -4 -4 -4\nf 1 2 3 4 5\n";
    expect_load_fail("OBJ collinear", line_obj, strlen(line_obj),
                     PHKS_FORMAT_AUTO, PHKS_ERROR_ZERO_AREA, "degenerate");
    /* slivers below 1e-12 of the squared bounding-box diagonal */
    static const char sliver_off[] =
        "OFF\n4 2 0\n0 0 0\n1 0 0\n0.5 1e-13 0\n0.5 -1e-13 0\n"
        "3 0 1 2\n3 0 3 1\n";
    expect_load_fail("OFF slivers", sliver_off, strlen(sliver_off),
                     PHKS_FORMAT_AUTO, PHKS_ERROR_ZERO_AREA, "degenerate");
    /* STL facets whose corners weld into repeated vertices */
    static const char welded_stl[] =
        "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
        "vertex 0 0 0\nvertex 1 1 1\nendloop\nendfacet\n"
        "facet normal 0 0 1\nouter loop\nvertex 2 0 0\nvertex -0 0 0\n"
        "vertex 0 0 -0\nendloop\nendfacet\nendsolid s\n";
    expect_load_fail("STL welded", welded_stl, strlen(welded_stl),
                     PHKS_FORMAT_AUTO, PHKS_ERROR_ZERO_AREA, "degenerate");
    /* a binary PLY whose vertices are all one point */
    bytes b = {0};
    put_text(&b, "ply\nformat binary_little_endian 1.0\nelement vertex 4\n"
                 "property float x\nproperty float y\nproperty float z\n"
                 "element face 2\nproperty list uchar uint vertex_indices\n"
                 "end_header\n");
    for (int k = 0; k < 12; k++)
        put_f32(&b, 7.5f, false);
    for (uint32_t f = 0; f < 2; f++) {
        put(&b, "\3", 1);
        for (uint32_t k = 0; k < 3; k++)
            put_u32(&b, f + k, false);
    }
    expect_load_fail("PLY one point", b.p, b.n, PHKS_FORMAT_AUTO,
                     PHKS_ERROR_ZERO_AREA, "degenerate");
    free(b.p);
    /* a binary STL of one facet with three equal corners */
    const float same[9] = {1, 2, 3, 1, 2, 3, 1, 2, 3};
    b = binary_stl(same, 1);
    expect_load_fail("STL one point", b.p, b.n, PHKS_FORMAT_AUTO,
                     PHKS_ERROR_ZERO_AREA, "degenerate");
    free(b.p);
}
END_TEST

/* -------------------------------------------------- counts and indices */

/* A billion elements declared in a 100-byte file: refused from the
 * header, before anything of that size is allocated. */
START_TEST(billion_declared_in_100_bytes)
{
    enum { FILES = 6 };
    bytes files[FILES] = {{0}};
    const char *names[FILES] = {"OFF vertices", "OFF faces", "PLY ascii",
                                "PLY binary", "PLY faces", "STL binary"};
    /* The PLY headers alone take about 100 bytes: 20 bytes of data follow. */
    const size_t sizes[FILES] = {100, 100, 0, 0, 0, 100};
    const phks_format formats[FILES] = {PHKS_FORMAT_AUTO, PHKS_FORMAT_AUTO,
                                        PHKS_FORMAT_AUTO, PHKS_FORMAT_AUTO,
                                        PHKS_FORMAT_AUTO, PHKS_FORMAT_STL};
    put_text(&files[0], "OFF\n1000000000 1 0\n");
    put_text(&files[1], "OFF\n3 1000000000 0\n0 0 0\n1 0 0\n0 1 0\n");
    put_text(&files[2], "ply\nformat ascii 1.0\nelement vertex 1000000000\n"
                        "property float x\nproperty float y\n"
                        "property float z\nend_header\n");
    put_text(&files[3], "ply\nformat binary_little_endian 1.0\n"
                        "element vertex 1000000000\nproperty uchar x\n"
                        "property uchar y\nproperty uchar z\nend_header\n");
    put_text(&files[4], "ply\nformat binary_little_endian 1.0\n"
                        "element face 1000000000\n"
                        "property list uchar int vertex_indices\nend_header\n");
    char header[80] = "binary STL";
    put(&files[5], header, 80);
    put_u32(&files[5], 1000000000u, false);
    for (int i = 0; i < FILES; i++) {
        pad_to(&files[i], sizes[i] ? sizes[i] : files[i].n + 20,
               i == 5 ? '\0' : '\n');
        probe_start();
        expect_load_fail(names[i], files[i].p, files[i].n, formats[i],
                         PHKS_ERROR_TOO_LARGE, i == 5 ? "byte offset 80" : "line");
        size_t largest = probe_stop();
        ck_assert_msg(largest < 65536, "%s: allocated %zu bytes", names[i], largest);
        free(files[i].p);
    }
    /* the largest count a file may declare, 2^32 - 2, and one more */
    static const char max_off[] = "OFF\n4294967294 1\n";
    expect_load_fail("OFF 2^32-2", max_off, strlen(max_off), PHKS_FORMAT_AUTO,
                     PHKS_ERROR_TOO_LARGE, "line 2");
    static const char over_ply[] =
        "ply\nformat ascii 1.0\nelement face 4294967295\nend_header\n";
    expect_load_fail("PLY 2^32-1", over_ply, strlen(over_ply), PHKS_FORMAT_AUTO,
                     PHKS_ERROR_TOO_LARGE, "line 3");
}
END_TEST

START_TEST(indices_at_uint32_max)
{
    static const struct {
        const char *what, *text, *needle;
    } texts[] = {
        {"OFF", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 4294967295\n", "line 6"},
        {"OFF 2^32", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 4294967296 1\n",
         "line 6"},
        {"OBJ", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4294967295\n", "line 4"},
        {"OBJ 2^32", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 4294967296 1 2\n", "line 4"},
        {"OBJ -2^32+1", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4294967295\n",
         "line 4"},
        {"PLY ascii",
         "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
         "property float y\nproperty float z\nelement face 1\n"
         "property list uchar uint vertex_indices\nend_header\n"
         "0 0 0\n1 0 0\n0 1 0\n3 0 4294967295 1\n",
         "line 13"},
    };
    for (size_t i = 0; i < sizeof texts / sizeof *texts; i++)
        expect_load_fail(texts[i].what, texts[i].text, strlen(texts[i].text),
                         PHKS_FORMAT_AUTO, PHKS_ERROR_INDEX_OUT_OF_RANGE,
                         texts[i].needle);
    /* binary PLY, unsigned 32-bit indices, both byte orders */
    for (int big = 0; big <= 1; big++) {
        bytes b = {0};
        put_text(&b, big ? "ply\nformat binary_big_endian 1.0\n"
                         : "ply\nformat binary_little_endian 1.0\n");
        put_text(&b, "element vertex 3\nproperty uchar x\nproperty uchar y\n"
                     "property uchar z\nelement face 1\n"
                     "property list uchar uint32 vertex_indices\nend_header\n");
        put(&b, "\0\0\0\1\0\0\0\1\0\3", 10);
        put_u32(&b, 0, big);
        put_u32(&b, UINT32_MAX, big);
        put_u32(&b, 1, big);
        expect_load_fail("PLY binary", b.p, b.n, PHKS_FORMAT_AUTO,
                         PHKS_ERROR_INDEX_OUT_OF_RANGE, "4294967295");
        free(b.p);
    }
    /* the constructor: UINT32_MAX is never a vertex */
    const double xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const uint32_t tri[3] = {0, UINT32_MAX, 1};
    phks_mesh *mesh;
    ck_assert_int_eq(phks_mesh_create(xyz, 3, tri, 1, &mesh),
                     PHKS_ERROR_INDEX_OUT_OF_RANGE);
    ck_assert_ptr_nonnull(strstr(phks_last_error_message(), "4294967295"));
}
END_TEST

/* ---------------------------------------------------------------- gzip */

static const char tetra_off[] = "OFF\n4 4 6\n0 0 0\n1.5 0 0\n0 2.25 0\n0 0 3\n"
                                "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";

/* Every proper prefix of a one-member and of a two-member file. */
START_TEST(truncated_gzip_every_prefix)
{
    size_t half = strlen(tetra_off) / 2;
    bytes one = gzip_of(tetra_off, strlen(tetra_off), 9);
    bytes a = gzip_of(tetra_off, half, 6);
    bytes b = gzip_of(tetra_off + half, strlen(tetra_off) - half, 6);
    put(&a, b.p, b.n);
    const bytes *files[2] = {&one, &a};
    for (int f = 0; f < 2; f++) {
        phks_mesh *mesh;
        ck_assert_int_eq(load(files[f]->p, files[f]->n, PHKS_FORMAT_AUTO, &mesh),
                         PHKS_OK);
        ck_assert_uint_eq(phks_mesh_triangle_count(mesh), 4);
        phks_mesh_free(mesh);
        for (size_t n = 0; n < files[f]->n; n++) {
            phks_status st = load(files[f]->p, n, PHKS_FORMAT_AUTO, &mesh);
            if (n < 2) { /* not even the magic bytes */
                ck_assert_int_eq(st, PHKS_ERROR_UNKNOWN_FORMAT);
                continue;
            }
            /* Cut before the second member's magic bytes are whole, the
             * first member is complete and the byte after it is taken for
             * padding: the half file then fails in the OFF reader. */
            bool whole_first = f == 1 && n >= a.n - b.n && n < a.n - b.n + 2;
            if (whole_first) {
                ck_assert_int_ne(st, PHKS_OK);
                continue;
            }
            ck_assert_msg(st == PHKS_ERROR_TRUNCATED || st == PHKS_ERROR_PARSE,
                          "file %d, %zu bytes: status %d (%s)", f, n, (int)st,
                          phks_last_error_message());
            ck_assert_msg(strstr(phks_last_error_message(), "gzip"),
                          "file %d, %zu bytes: \"%s\"", f, n,
                          phks_last_error_message());
        }
    }
    free(one.p);
    free(a.p);
    free(b.p);
}
END_TEST

/* The trailer's size field (the last four bytes) is believed only as far
 * as deflate can expand: a lie cannot make the loader reserve gigabytes. */
START_TEST(gzip_size_field_lies)
{
    bytes gz = gzip_of(tetra_off, strlen(tetra_off), 9);
    /* a wrong ISIZE in the member itself: zlib's length check refuses it */
    memcpy(gz.p + gz.n - 4, "\xff\xff\xff\xff", 4);
    probe_start();
    expect_load_fail("lying ISIZE", gz.p, gz.n, PHKS_FORMAT_AUTO,
                     PHKS_ERROR_PARSE, "gzip");
    ck_assert_uint_lt(probe_stop(), 1u << 20);
    /* valid data followed by padding whose last bytes look like a size */
    bytes good = gzip_of(tetra_off, strlen(tetra_off), 9);
    put(&good, "\0\0\0\0\xff\xff\xff\x7f", 8);
    probe_start();
    phks_mesh *mesh;
    ck_assert_int_eq(load(good.p, good.n, PHKS_FORMAT_AUTO, &mesh), PHKS_OK);
    ck_assert_uint_lt(probe_stop(), 1u << 20);
    phks_mesh_free(mesh);
    free(gz.p);
    free(good.p);
}
END_TEST

/* 100 MB of zeros in under 500 kB: under the 2 GiB cap, so it inflates,
 * but then fails fast in detection or in the reader, without holding more
 * than the inflated bytes. */
START_TEST(gzip_bomb)
{
    const size_t zeros = (size_t)100 << 20;
    double t0 = cpu_now();
    bytes bomb = gzip_zeros(zeros);
    double made = cpu_now() - t0;
    ck_assert_uint_lt(bomb.n, zeros / 200);
    static const struct {
        phks_format format;
        phks_status status;
    } cases[] = {{PHKS_FORMAT_AUTO, PHKS_ERROR_UNKNOWN_FORMAT},
                 {PHKS_FORMAT_STL, PHKS_ERROR_NO_TRIANGLES}};
    long grown = 0;
    double took[2];
    size_t peak[2];
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        phks_mesh *mesh;
        long rss0 = max_rss_kib();
        meter_start();
        t0 = cpu_now();
        ck_assert_int_eq(load(bomb.p, bomb.n, cases[i].format, &mesh),
                         cases[i].status);
        took[i] = cpu_now() - t0;
        /* the library held the inflated bytes and little more */
        peak[i] = meter_stop();
        ck_assert_msg(peak[i] <= zeros + 1 + GZIP_OVERHEAD,
                      "format %d: the library held %zu bytes at its peak",
                      (int)cases[i].format, peak[i]);
        /* only the first load: ASan holds freed blocks back for a while */
        if (i == 0)
            grown = max_rss_kib() - rss0;
    }
    printf("gzip_bomb: %zu bytes made in %.2f s, refused in %.2f s and "
           "%.2f s (CPU), holding at most %zu and %zu bytes; peak memory "
           "grew %ld MiB\n",
           bomb.n, made, took[0], took[1], peak[0], peak[1], grown / 1024);
    /* the inflated 100 MiB, plus a margin */
    ck_assert_msg(grown < 160 * 1024, "peak memory grew %ld KiB", grown);
    free(bomb.p);
}
END_TEST

/* ----------------------------------------------------------- signatures */

static bytes signature_blob(void)
{
    phks_signature *sig;
    ck_assert_int_eq(phks__signature_alloc(2, 0, 15, &sig), PHKS_OK);
    phks_options_init(&sig->options);
    sig->options.matching = PHKS_MATCHING_NEAREST;
    for (size_t i = 0; i < 2; i++) {
        sig->vertex[i] = (uint32_t)i;
        for (int d = 0; d < 3; d++)
            sig->position[3 * i + d] = (double)d;
        sig->persistence[i] = i ? 0.5 : INFINITY;
        for (size_t s = 0; s < 15; s++)
            sig->vectors[15 * i + s] = 1.0 / (double)(1 + s);
    }
    bytes b = {0};
    b.cap = b.n = phks_signature_encoded_size(sig);
    b.p = malloc(b.n);
    size_t size;
    ck_assert_int_eq(phks_signature_encode(sig, b.p, b.n, &size), PHKS_OK);
    phks_signature_free(sig);
    return b;
}

static void reseal(bytes *b)
{
    uint32_t crc = phks__crc32(b->p, b->n - 4);
    for (int i = 0; i < 4; i++)
        b->p[b->n - 4 + i] = (unsigned char)(crc >> (8 * i));
}

/* Regression: the message for impossible options in a blob was printed
 * into the buffer it quoted, and came out as "signature blob: bad options
 * (signature blob: bad options (...". */
START_TEST(signature_bad_options_message)
{
    bytes b = signature_blob();
    double tau = -1; /* the first field after magic, format and flags */
    uint64_t u;
    memcpy(&u, &tau, 8);
    for (int i = 0; i < 8; i++)
        b.p[8 + i] = (unsigned char)(u >> (8 * i));
    reseal(&b);
    phks_signature *sig = (phks_signature *)&b;
    ck_assert_int_eq(phks_signature_decode(b.p, b.n, &sig), PHKS_ERROR_CORRUPT);
    ck_assert_ptr_null(sig);
    const char *m = phks_last_error_message();
    const char *first = strstr(m, "signature blob");
    ck_assert_msg(first && !strstr(first + 1, "signature blob"), "\"%s\"", m);
    ck_assert_msg(strstr(m, "tau"), "\"%s\"", m);
    free(b.p);
}
END_TEST

/* A blob that declares 2^32 - 1 features in a few hundred bytes is refused
 * before any allocation of that size. */
START_TEST(signature_count_lies)
{
    bytes b = signature_blob();
    size_t count_at = b.n - 4 - 2 * (4 + 4 * 8 + 15 * 8) - 4;
    ck_assert_uint_eq(b.p[count_at], 2);
    memcpy(b.p + count_at, "\xff\xff\xff\xff", 4);
    reseal(&b);
    probe_start();
    phks_signature *sig;
    ck_assert_int_eq(phks_signature_decode(b.p, b.n, &sig), PHKS_ERROR_TRUNCATED);
    ck_assert_uint_lt(probe_stop(), 4096);
    free(b.p);
}
END_TEST

/* ---------------------------------------------------------------- limits */

/* A strip of `n` vertices and n - 2 triangles along x, as OFF text. */
static bytes strip_off(size_t n)
{
    bytes b = {0};
    char line[96];
    snprintf(line, sizeof line, "OFF\n%zu %zu 0\n", n, n - 2);
    put_text(&b, line);
    for (size_t i = 0; i < n; i++) {
        snprintf(line, sizeof line, "%zu %d 0\n", i / 2, (int)(i % 2));
        put_text(&b, line);
    }
    for (size_t i = 0; i + 2 < n; i++) {
        snprintf(line, sizeof line, "3 %zu %zu %zu\n", i, i + 1, i + 2);
        put_text(&b, line);
    }
    return b;
}

static phks_status load_limited(const bytes *b, size_t max_bytes,
                                size_t max_vertices, phks_mesh **mesh)
{
    *mesh = (phks_mesh *)b; /* must be overwritten */
    phks_status st = phks_mesh_load_memory_limited(
        b->p, b->n, PHKS_FORMAT_AUTO, max_bytes, max_vertices, mesh);
    if (st != PHKS_OK)
        ck_assert_ptr_null(*mesh);
    return st;
}

static void expect_limited_fail(const bytes *b, size_t max_bytes,
                                size_t max_vertices, const char *needle)
{
    phks_mesh *mesh;
    ck_assert_int_eq(load_limited(b, max_bytes, max_vertices, &mesh),
                     PHKS_ERROR_TOO_LARGE);
    const char *m = phks_last_error_message();
    ck_assert_msg(strstr(m, needle) != NULL, "message \"%s\" lacks \"%s\"", m,
                  needle);
}

/* Exactly at each limit the mesh loads; one past it, it is refused with a
 * message giving the limit, plain and gzipped. */
START_TEST(load_limits_exact)
{
    const size_t n = 500;
    bytes off = strip_off(n);
    bytes gz = gzip_of(off.p, off.n, 6);
    const bytes *forms[] = {&off, &gz};
    char needle[96];
    for (int f = 0; f < 2; f++) {
        phks_mesh *mesh;
        ck_assert_int_eq(load_limited(forms[f], off.n, n, &mesh), PHKS_OK);
        ck_assert_uint_eq(phks_mesh_vertex_count(mesh), n);
        phks_mesh_free(mesh);
        ck_assert_int_eq(load_limited(forms[f], 0, 0, &mesh), PHKS_OK);
        phks_mesh_free(mesh);

        snprintf(needle, sizeof needle,
                 "the mesh has %zu vertices, more than the limit of %zu", n,
                 n - 1);
        expect_limited_fail(forms[f], 0, n - 1, needle);
        snprintf(needle, sizeof needle, "more than %s%zu",
                 f == 0 ? "the limit of " : "", off.n - 1);
        expect_limited_fail(forms[f], off.n - 1, 0, needle);
    }
    free(off.p);
    free(gz.p);
}
END_TEST

/* Plain data over max_bytes is refused before the library allocates; gzip
 * data stops inflating at the limit. */
START_TEST(load_limits_hold_memory)
{
    const size_t limit = (size_t)1 << 20;
    bytes plain = strip_off(200000);
    ck_assert_uint_gt(plain.n, limit);
    probe_start();
    expect_limited_fail(&plain, limit, 0, "bytes of mesh data");
    ck_assert_uint_eq(probe_stop(), 0);

    bytes bomb = gzip_zeros((size_t)64 << 20);
    meter_start();
    expect_limited_fail(&bomb, limit, 0, "inflates to more than");
    ck_assert_uint_le(meter_stop(), limit + 1 + GZIP_OVERHEAD);

    /* Within max_bytes, the densest vertex lines ("v 0 0 0\n", 8 bytes
     * for 24 of coordinates) are what reading holds most for: the peak
     * stays within the four times max_bytes that phks.h promises. */
    bytes dense = {0};
    while (dense.n + 16 <= limit)
        put_text(&dense, "v 0 0 0\n");
    put_text(&dense, "f 1 2 3\n");
    meter_start();
    expect_limited_fail(&dense, limit, 1000, "vertices, more than");
    size_t peak = meter_stop();
    printf("load_limits_hold_memory: %zu bytes of vertex lines held at most "
           "%zu bytes (%.2f times)\n",
           dense.n, peak, (double)peak / (double)dense.n);
    ck_assert_uint_le(peak, 4 * limit);
    free(plain.p);
    free(bomb.p);
    free(dense.p);
}
END_TEST

#else /* PHKS_GZIP_LIMIT */

/* ------------------------------------------- the gzip cap, made small */

/* Built with PHKS_GZIP_LIMIT lowered: a stream that inflates past it is
 * refused with TOO_LARGE once the limit is reached, holding no more than
 * the limit; exactly the limit is accepted by the inflater. */
START_TEST(gzip_limit)
{
    const size_t limit = PHKS_GZIP_LIMIT;
    phks_mesh *mesh;
    bytes at = gzip_zeros(limit);
    ck_assert_int_eq(load(at.p, at.n, PHKS_FORMAT_AUTO, &mesh),
                     PHKS_ERROR_UNKNOWN_FORMAT);
    free(at.p);

    bytes over = gzip_zeros(limit + 1);
    probe_start();
    long rss0 = max_rss_kib();
    expect_load_fail("one byte over", over.p, over.n, PHKS_FORMAT_AUTO,
                     PHKS_ERROR_TOO_LARGE, "gzip data inflates to more than");
    ck_assert_uint_le(probe_stop(), limit + 1);
    free(over.p);

    /* a bomb of 8 times the limit, as one member and as 64; the bytes the
     * library holds at once stay within the limit (plus zlib's) */
    bytes bomb = gzip_zeros(8 * limit);
    meter_start();
    expect_load_fail("bomb", bomb.p, bomb.n, PHKS_FORMAT_OFF,
                     PHKS_ERROR_TOO_LARGE, "inflates");
    size_t peak_bomb = meter_stop();
    ck_assert_uint_le(peak_bomb, limit + 1 + GZIP_OVERHEAD);
    bytes member = gzip_zeros(limit / 4);
    bytes many = {0};
    for (int i = 0; i < 64; i++)
        put(&many, member.p, member.n);
    meter_start();
    expect_load_fail("members", many.p, many.n, PHKS_FORMAT_AUTO,
                     PHKS_ERROR_TOO_LARGE, "inflates");
    size_t peak_members = meter_stop();
    ck_assert_uint_le(largest_request, limit + 1);
    ck_assert_uint_le(peak_members, limit + 1 + GZIP_OVERHEAD);
    long grown = max_rss_kib() - rss0;
    ck_assert_msg(grown < (long)(4 * limit / 1024) + 64 * 1024,
                  "peak memory grew %ld KiB", grown);

    /* from a file, the compressed bytes are held too while they inflate */
    char path[] = "/tmp/phks-bomb-XXXXXX";
    int fd = mkstemp(path);
    ck_assert_int_ge(fd, 0);
    ck_assert(write(fd, many.p, many.n) == (ssize_t)many.n);
    ck_assert_int_eq(close(fd), 0);
    phks_mesh *from_file = (phks_mesh *)&many;
    meter_start();
    ck_assert_int_eq(phks_mesh_load(path, &from_file), PHKS_ERROR_TOO_LARGE);
    size_t peak_file = meter_stop();
    ck_assert_ptr_null(from_file);
    ck_assert_int_eq(unlink(path), 0);
    ck_assert_uint_le(peak_file, limit + 1 + many.n + GZIP_OVERHEAD);
    printf("gzip_limit: %zu bytes allowed; the library held at most %zu "
           "(bomb), %zu (64 members) and %zu (64 members, %zu bytes, from a "
           "file)\n",
           limit, peak_bomb, peak_members, peak_file, many.n);
    free(bomb.p);
    free(member.p);
    free(many.p);
}
END_TEST

#endif /* PHKS_GZIP_LIMIT */

/* ---------------------------------------------------------------- suite */

int main(void)
{
    Suite *s = suite_create("hostile");
#ifndef PHKS_GZIP_LIMIT
    TCase *numbers = tcase_create("numbers");
    tcase_add_test(numbers, non_finite_coordinates);
    tcase_add_test(numbers, extreme_finite_coordinates);
    tcase_add_test(numbers, triangle_area_is_unchanged_at_ordinary_scales);
    tcase_add_test(numbers, meshes_without_area);
    suite_add_tcase(s, numbers);

    TCase *counts = tcase_create("counts");
    tcase_add_test(counts, billion_declared_in_100_bytes);
    tcase_add_test(counts, indices_at_uint32_max);
    suite_add_tcase(s, counts);

    TCase *gzip = tcase_create("gzip");
    tcase_add_test(gzip, truncated_gzip_every_prefix);
    tcase_add_test(gzip, gzip_size_field_lies);
    tcase_add_test(gzip, gzip_bomb);
    suite_add_tcase(s, gzip);

    TCase *codec = tcase_create("signatures");
    tcase_add_test(codec, signature_bad_options_message);
    tcase_add_test(codec, signature_count_lies);
    suite_add_tcase(s, codec);

    TCase *limits = tcase_create("limits");
    tcase_add_test(limits, load_limits_exact);
    tcase_add_test(limits, load_limits_hold_memory);
    suite_add_tcase(s, limits);
#else
    TCase *limit = tcase_create("gzip_limit");
    tcase_add_test(limit, gzip_limit);
    suite_add_tcase(s, limit);
#endif
    return run_suite(s);
}
