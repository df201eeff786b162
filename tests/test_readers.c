/*
 * test_readers.c - the mesh file readers (OFF, OBJ, PLY, STL), the number
 * scanner under them, and the loader: gzip, format detection, file errors.
 * Every reader runs on an exact-size heap copy of its input, so the
 * sanitizer build catches any read past the end of the buffer.
 */
#include "testutil.h"
#include "io/text_scan.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

typedef phks_status (*reader_fn)(const char *, size_t, phks__raw_mesh *);

/* ------------------------------------------------------------- helpers */

static phks_status run_reader(reader_fn fn, const void *data, size_t len,
                              phks__raw_mesh *raw)
{
    char *copy = malloc(len ? len : 1);
    ck_assert_ptr_nonnull(copy);
    memcpy(copy, data, len);
    phks_status st = fn(copy, len, raw);
    free(copy);
    return st;
}

#define READ(fn, literal, raw) run_reader(fn, literal, sizeof literal - 1, raw)

static void expect_message(const char *needle)
{
    const char *m = phks_last_error_message();
    ck_assert_msg(strstr(m, needle) != NULL, "message \"%s\" lacks \"%s\"", m,
                  needle);
}

static void expect_fail_n(reader_fn fn, const void *data, size_t len,
                          phks_status want, const char *needle)
{
    phks__raw_mesh raw;
    phks_status st = run_reader(fn, data, len, &raw);
    ck_assert_msg(st == want, "status %d (%s), wanted %d; message \"%s\"",
                  (int)st, phks_status_string(st), (int)want,
                  phks_last_error_message());
    ck_assert_ptr_null(raw.xyz);
    ck_assert_ptr_null(raw.triangles);
    ck_assert_ptr_null(raw.vertex_origin);
    expect_message(needle);
}

#define EXPECT_FAIL(fn, literal, status, needle) \
    expect_fail_n(fn, literal, sizeof literal - 1, status, needle)

static void expect_vertex(const phks__raw_mesh *raw, size_t v, double x,
                          double y, double z)
{
    ck_assert_uint_lt(v, raw->vertex_count);
    ck_assert_double_eq(raw->xyz[3 * v], x);
    ck_assert_double_eq(raw->xyz[3 * v + 1], y);
    ck_assert_double_eq(raw->xyz[3 * v + 2], z);
}

static void expect_triangles(const phks__raw_mesh *raw, const uint32_t *tri,
                             size_t count)
{
    ck_assert_uint_eq(raw->triangle_count, count);
    for (size_t i = 0; i < 3 * count; i++)
        ck_assert_msg(raw->triangles[i] == tri[i],
                      "triangle %zu corner %zu: %u, wanted %u", i / 3, i % 3,
                      raw->triangles[i], tri[i]);
}

/* The tetrahedron most tests use. */
static const double tetra_xyz[12] = {0, 0, 0, 1.5, 0, 0, 0, 2.25, 0, 0, 0, 3};
static const uint32_t tetra_tri[12] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};

static void expect_tetra(const phks__raw_mesh *raw)
{
    ck_assert_uint_eq(raw->vertex_count, 4);
    for (size_t v = 0; v < 4; v++)
        expect_vertex(raw, v, tetra_xyz[3 * v], tetra_xyz[3 * v + 1],
                      tetra_xyz[3 * v + 2]);
    expect_triangles(raw, tetra_tri, 4);
    ck_assert_ptr_null(raw->vertex_origin);
}

static const char tetra_off[] = "OFF\n"
                                "4 4 6\n"
                                "0 0 0\n"
                                "1.5 0 0\n"
                                "0 2.25 0\n"
                                "0 0 3\n"
                                "3 0 2 1\n"
                                "3 0 1 3\n"
                                "3 0 3 2\n"
                                "3 1 2 3\n";

static const char tetra_obj[] = "# a tetrahedron\n"
                                "v 0 0 0\n"
                                "v 1.5 0 0\n"
                                "v 0 2.25 0\n"
                                "v 0 0 3\n"
                                "f 1 3 2\n"
                                "f 1 2 4\n"
                                "f 1 4 3\n"
                                "f 2 3 4\n";

static const char tetra_ply[] = "ply\n"
                                "format ascii 1.0\n"
                                "element vertex 4\n"
                                "property float x\n"
                                "property float y\n"
                                "property float z\n"
                                "element face 4\n"
                                "property list uchar int vertex_indices\n"
                                "end_header\n"
                                "0 0 0\n1.5 0 0\n0 2.25 0\n0 0 3\n"
                                "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";

/* Two triangles sharing the edge B-C: A B C and B D C. */
static const char two_stl[] = "solid two\n"
                              "  facet normal 0 0 1\n"
                              "    outer loop\n"
                              "      vertex 0 0 0\n"
                              "      vertex 1 0 0\n"
                              "      vertex 0 1 0\n"
                              "    endloop\n"
                              "  endfacet\n"
                              "  facet normal 0 0 1\n"
                              "    outer loop\n"
                              "      vertex 1 0 0\n"
                              "      vertex 1 1 0\n"
                              "      vertex 0 1 0\n"
                              "    endloop\n"
                              "  endfacet\n"
                              "endsolid two\n";

static void expect_two_triangles(const phks__raw_mesh *raw)
{
    static const uint32_t tri[6] = {0, 1, 2, 1, 3, 2};
    static const uint32_t origin[4] = {0, 1, 2, 4};
    ck_assert_uint_eq(raw->vertex_count, 4);
    expect_vertex(raw, 0, 0, 0, 0);
    expect_vertex(raw, 1, 1, 0, 0);
    expect_vertex(raw, 2, 0, 1, 0);
    expect_vertex(raw, 3, 1, 1, 0);
    expect_triangles(raw, tri, 2);
    ck_assert_ptr_nonnull(raw->vertex_origin);
    for (size_t v = 0; v < 4; v++)
        ck_assert_uint_eq(raw->vertex_origin[v], origin[v]);
}

static void put_text(bytes *b, const char *s)
{
    put(b, s, strlen(s));
}

static void put_le32(bytes *b, uint32_t v)
{
    unsigned char c[4] = {(unsigned char)v, (unsigned char)(v >> 8),
                          (unsigned char)(v >> 16), (unsigned char)(v >> 24)};
    put(b, c, 4);
}

static void put_f32le(bytes *b, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    put_le32(b, u);
}

/* ----------------------------------------------------------- text_scan */

static void expect_same_as_strtod(const char *text)
{
    double got = -1, want = strtod(text, NULL);
    const char *stop = NULL;
    phks__scan_result r = phks__parse_double(text, text + strlen(text), &got, &stop);
    /* Check records every passing assertion in a file, which is slow in
     * loops this long: only failures reach it. */
    if (!isfinite(want)) {
        if (r != PHKS__SCAN_NON_FINITE)
            ck_abort_msg("'%s': result %d", text, (int)r);
        return;
    }
    if (r != PHKS__SCAN_OK || stop != text + strlen(text))
        ck_abort_msg("'%s': result %d", text, (int)r);
    if (memcmp(&got, &want, sizeof got) != 0)
        ck_abort_msg("'%s': got %.17g, strtod %.17g", text, got, want);
}

START_TEST(scan_parse_double_matches_strtod)
{
    static const char *fixed[] = {
        "0", "-0", "+1", "1.", ".5", "-.5", "1e3", "1E+3", "1e-3", "123.456e-2",
        "0.000001234", "9007199254740993", "9007199254740992.5",
        "2.2250738585072011e-308", "2.2250738585072014e-308",
        "4.9406564584124654e-324", "2.4703282292062327e-324",
        "2.4703282292062328e-324", "1.7976931348623157e308",
        "1.7976931348623158e308", "1.7976931348623159e308", "1e309",
        "1e-400", "0.1", "0.2", "0.3", "123456789012345678901234567890",
        "0.000000000000000000000000000000000000000001e42",
        "7.2057594037927933e16", "1e22", "1e23", "8.98846567431158e307",
        "3.14159265358979323846264338327950288419716939937510582097494459"};
    for (size_t i = 0; i < sizeof fixed / sizeof *fixed; i++)
        expect_same_as_strtod(fixed[i]);

    /* A number longer than the digits kept, with the deciding digit at the
     * far end: 2^-1074 * 1.5 (a halfway point) plus a tiny bit. */
    char longest[1200];
    snprintf(longest, sizeof longest, "%.1000e",
             7.4109846876186982e-324); /* 1.5 * 2^-1074 */
    expect_same_as_strtod(longest);

    uint64_t state = 42;
    static const char *formats[] = {"%.17g", "%.6f", "%.3e", "%.0f", "%.25g", "%g"};
    for (int i = 0; i < 20000; i++) {
        double magnitude = pow(10, 40 * test_random(&state) - 20);
        double v = (test_random(&state) - 0.5) * magnitude;
        char text[128];
        snprintf(text, sizeof text, formats[i % 6], v);
        expect_same_as_strtod(text);
    }
    for (int i = 0; i < 5000; i++) { /* random digit strings */
        char text[96];
        size_t n = 0;
        int digits = 1 + (int)(40 * test_random(&state));
        int point = (int)(digits * test_random(&state));
        for (int d = 0; d < digits; d++) {
            if (d == point)
                text[n++] = '.';
            text[n++] = (char)('0' + (int)(10 * test_random(&state)));
        }
        snprintf(text + n, sizeof text - n, "e%d",
                 (int)(700 * test_random(&state)) - 350);
        expect_same_as_strtod(text);
    }
}
END_TEST

START_TEST(scan_parse_special_values)
{
    static const char *non_finite[] = {"nan", "NaN", "-nan", "inf", "-Inf",
                                       "infinity", "nan(0x1)", "1.#INF",
                                       "-1.#IND", "1.#QNAN", "1e999"};
    for (size_t i = 0; i < sizeof non_finite / sizeof *non_finite; i++) {
        const char *t = non_finite[i], *stop;
        double v;
        ck_assert_msg(phks__parse_double(t, t + strlen(t), &v, &stop) ==
                          PHKS__SCAN_NON_FINITE,
                      "'%s'", t);
    }
    static const char *bad[] = {"", "-", ".", "e5", "x", "+-1", "in", "#"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        const char *t = bad[i], *stop;
        double v;
        ck_assert_msg(phks__parse_double(t, t + strlen(t), &v, &stop) ==
                          PHKS__SCAN_BAD,
                      "'%s'", t);
    }
    /* Stops at the end of the buffer, not at a NUL. */
    const char digits[] = "12345";
    const char *stop;
    double v;
    ck_assert_int_eq(phks__parse_double(digits, digits + 3, &v, &stop),
                     PHKS__SCAN_OK);
    ck_assert_double_eq(v, 123);
    int64_t i;
    ck_assert_int_eq(phks__parse_int(digits, digits + 2, &i, &stop), PHKS__SCAN_OK);
    ck_assert_int_eq(i, 12);
    const char *big = "9223372036854775808";
    ck_assert_int_eq(phks__parse_int(big, big + strlen(big), &i, &stop),
                     PHKS__SCAN_RANGE);
    const char *min = "-9223372036854775807";
    ck_assert_int_eq(phks__parse_int(min, min + strlen(min), &i, &stop), PHKS__SCAN_OK);
    ck_assert(i == -INT64_MAX);
}
END_TEST

START_TEST(scan_counts_lines)
{
    const char text[] = "a b # c\n\n  # d\r\nx 1.5 2\\\n 3";
    phks__scan s;
    phks__scan_init(&s, text, sizeof text - 1);
    s.comment = '#';
    s.continuation = true;
    const char *t;
    ck_assert_uint_eq(phks__scan_token(&s, &t), 1);
    ck_assert_uint_eq(phks__scan_token(&s, &t), 1);
    ck_assert(phks__scan_eol(&s));
    phks__scan_space(&s);
    ck_assert_uint_eq(s.line, 4);
    ck_assert_uint_eq(phks__scan_token(&s, &t), 1);
    double v;
    ck_assert_int_eq(phks__scan_double(&s, &v), PHKS__SCAN_OK);
    ck_assert_double_eq(v, 1.5);
    ck_assert_int_eq(phks__scan_double(&s, &v), PHKS__SCAN_BAD); /* "2\" */
}
END_TEST

/* ----------------------------------------------------------------- OFF */

START_TEST(off_tetrahedron)
{
    phks__raw_mesh raw;
    ck_assert_int_eq(READ(phks__read_off, tetra_off, &raw), PHKS_OK);
    expect_tetra(&raw);
    phks__raw_mesh_release(&raw);
}
END_TEST

START_TEST(off_header_forms)
{
    static const char counts_on_header[] =
        "# made by hand\n"
        "OFF 4 4 6 # counts\r\n"
        "\n"
        "# vertices\r\n"
        "0 0 0\r\n1.5 0 0\r\n0 2.25 0\r\n0 0 3\r\n"
        "3 0 2 1\r\n3 0 1 3\r\n# a comment between faces\n3 0 3 2\r\n3 1 2 3";
    static const char no_edge_count[] =
        "OFF\n4 4\n0 0 0\n1.5 0 0\n0 2.25 0\n0 0 3\n"
        "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
    static const char colours[] =
        "COFF\n4 4 6\n"
        "0 0 0 255 0 0 255\n1.5 0 0 0 255 0 255\n0 2.25 0 0 0 255 255\n"
        "0 0 3 1 1 1 1\n"
        "3 0 2 1 1.0 0.0 0.0 1.0\n3 0 1 3 255 0 0\n3 0 3 2\n3 1 2 3 7\n";
    static const char normals[] =
        "NOFF\n4 4 6\n"
        "0 0 0 0 0 1\n1.5 0 0 0 0 1\n0 2.25 0 0 0 1\n0 0 3 0 0 1\n"
        "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
    static const char textures[] =
        "STCNOFF\n4 4 6\n"
        "0 0 0 0 0 1 .5 .5 1 1 1 1\n1.5 0 0 0 0 1 0 0 0 0 0 1\n"
        "0 2.25 0 0 0 1 1 1 1 1 1 1\n0 0 3 0 0 1 0 0 0 0 0 0\n"
        "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
    const char *texts[] = {counts_on_header, no_edge_count, colours, normals,
                           textures};
    for (size_t i = 0; i < 5; i++) {
        phks__raw_mesh raw;
        phks_status st = run_reader(phks__read_off, texts[i], strlen(texts[i]), &raw);
        ck_assert_msg(st == PHKS_OK, "text %zu: %s", i, phks_last_error_message());
        expect_tetra(&raw);
        phks__raw_mesh_release(&raw);
    }
}
END_TEST

START_TEST(off_polygons_fan)
{
    static const char text[] = "OFF\n5 2 0\n"
                               "0 0 0\n1 0 0\n1 1 0\n0 1 0\n-1 0.5 1e-1\n"
                               "4 0 1 2 3\n"
                               "5 4 0 1 2 3\n";
    static const uint32_t tri[15] = {0, 1, 2, 0, 2, 3, 4, 0, 1, 4, 1, 2, 4, 2, 3};
    phks__raw_mesh raw;
    ck_assert_int_eq(READ(phks__read_off, text, &raw), PHKS_OK);
    ck_assert_uint_eq(raw.vertex_count, 5);
    expect_vertex(&raw, 4, -1, 0.5, 0.1);
    expect_triangles(&raw, tri, 5);
    phks__raw_mesh_release(&raw);
}
END_TEST

START_TEST(off_errors)
{
    EXPECT_FAIL(phks__read_off, "", PHKS_ERROR_TRUNCATED, "line 1");
    EXPECT_FAIL(phks__read_off, "PLY\n", PHKS_ERROR_PARSE, "line 1");
    EXPECT_FAIL(phks__read_off, "# c\n4OFF\n1 1 0\n0 0 0 1\n", PHKS_ERROR_PARSE,
                "line 2");
    EXPECT_FAIL(phks__read_off, "OFF BINARY\n", PHKS_ERROR_PARSE, "line 1");
    EXPECT_FAIL(phks__read_off, "OFF\n-4 4 0\n", PHKS_ERROR_PARSE, "line 2");
    EXPECT_FAIL(phks__read_off, "OFF\n4 x 0\n", PHKS_ERROR_PARSE, "line 2");
    EXPECT_FAIL(phks__read_off, "OFF\n4 4 x\n", PHKS_ERROR_PARSE, "line 2");
    EXPECT_FAIL(phks__read_off, "OFF\n4\n", PHKS_ERROR_TRUNCATED, "line 3");
    /* counts the data cannot hold, refused before any allocation */
    EXPECT_FAIL(phks__read_off, "OFF\n1000000000 1 0\n0 0 0\n", PHKS_ERROR_TOO_LARGE,
                "line 2");
    EXPECT_FAIL(phks__read_off, "OFF\n4294967295 1 0\n", PHKS_ERROR_TOO_LARGE,
                "line 2");
    EXPECT_FAIL(phks__read_off, "OFF\n99999999999999999999 1 0\n", PHKS_ERROR_TOO_LARGE,
                "line 2");
    EXPECT_FAIL(phks__read_off, "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n",
                PHKS_ERROR_NO_TRIANGLES, "line 2");
    /* vertices */
    EXPECT_FAIL(phks__read_off, "OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n",
                PHKS_ERROR_NON_FINITE, "line 4");
    EXPECT_FAIL(phks__read_off, "OFF\n3 1 0\n0 0 0\n1 -inf 0\n0 1 0\n3 0 1 2\n",
                PHKS_ERROR_NON_FINITE, "line 4");
    EXPECT_FAIL(phks__read_off, "OFF\n3 1 0\n0 0 0\n1 0 1e999\n0 1 0\n3 0 1 2\n",
                PHKS_ERROR_NON_FINITE, "line 4");
    EXPECT_FAIL(phks__read_off, "OFF\n3 1 0\n0 0 0\n1 0 1.#INF\n0 1 0\n3 0 1 2\n",
                PHKS_ERROR_NON_FINITE, "line 4");
    EXPECT_FAIL(phks__read_off, "OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n# padding\n",
                PHKS_ERROR_PARSE, "line 4");
    EXPECT_FAIL(phks__read_off, "OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n",
                PHKS_ERROR_PARSE, "line 4");
    EXPECT_FAIL(phks__read_off, "OFF\n3 1 0\n0 0 0\n1 0.5.5 0\n0 1 0\n3 0 1 2\n",
                PHKS_ERROR_PARSE, "line 4");
    EXPECT_FAIL(phks__read_off,
                "OFF\n3 1 0\n0.000000 0.000000 0.000000\n"
                "1.000000 0.000000 0.000000\n",
                PHKS_ERROR_TRUNCATED, "line 5");
    /* faces */
    EXPECT_FAIL(phks__read_off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
                PHKS_ERROR_INDEX_OUT_OF_RANGE, "line 6");
    EXPECT_FAIL(phks__read_off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n",
                PHKS_ERROR_INDEX_OUT_OF_RANGE, "line 6");
    EXPECT_FAIL(phks__read_off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n# padding\n",
                PHKS_ERROR_PARSE, "line 6");
    EXPECT_FAIL(phks__read_off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n# padding\n",
                PHKS_ERROR_PARSE, "line 6");
    EXPECT_FAIL(phks__read_off,
                "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n1000000000 0 1 2\n",
                PHKS_ERROR_PARSE, "line 6");
    EXPECT_FAIL(phks__read_off,
                "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n# padding\n",
                PHKS_ERROR_TRUNCATED, "line 8");
}
END_TEST

/* ----------------------------------------------------------------- OBJ */

START_TEST(obj_tetrahedron)
{
    phks__raw_mesh raw;
    ck_assert_int_eq(READ(phks__read_obj, tetra_obj, &raw), PHKS_OK);
    expect_tetra(&raw);
    phks__raw_mesh_release(&raw);
}
END_TEST

START_TEST(obj_statements_ignored)
{
    static const char text[] =
        "mtllib tetra.mtl\r\n"
        "o tetra\n"
        "v 0 0 0 1\n"
        "v 1.5 0 0 0.5 0.5 0.5\n"
        "\tv   0 2.25 0\n"
        "v 0 0 3 # the apex\n"
        "vt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\n"
        "vn 0 0 1\nvn 0 1 0\nvn 1 0 0\nvn 1 1 1\n"
        "vp 0.5\n"
        "g side\ns 1\nusemtl red\n"
        "f 1/1 3/3 2/2\n"
        "f 1//1 2//2 4//4\n"
        "f 1/1/1 4/4/4 3/3/3\n"
        "s off\n"
        "l 1 2\np 3\n"
        "f 2/2/ 3/ 4 # trailing comment\n";
    phks__raw_mesh raw;
    ck_assert_int_eq(READ(phks__read_obj, text, &raw), PHKS_OK);
    expect_tetra(&raw);
    phks__raw_mesh_release(&raw);
}
END_TEST

START_TEST(obj_polygons_negative_continuation)
{
    static const char text[] = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                               "f -4 -3 -2 -1\n"
                               "v -1 0.5 0.1\n"
                               "f 5 1 2 \\\n 3 4\n"
                               "f 3 -2/1/1 1\n";
    static const uint32_t tri[18] = {0, 1, 2, 0, 2, 3, 4, 0, 1,
                                     4, 1, 2, 4, 2, 3, 2, 3, 0};
    phks__raw_mesh raw;
    ck_assert_int_eq(READ(phks__read_obj, text, &raw), PHKS_OK);
    ck_assert_uint_eq(raw.vertex_count, 5);
    expect_vertex(&raw, 4, -1, 0.5, 0.1);
    expect_triangles(&raw, tri, 6);
    phks__raw_mesh_release(&raw);
}
END_TEST

START_TEST(obj_faces_before_vertices)
{
    static const char text[] = "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n";
    static const uint32_t tri[3] = {0, 1, 2};
    phks__raw_mesh raw;
    ck_assert_int_eq(READ(phks__read_obj, text, &raw), PHKS_OK);
    expect_triangles(&raw, tri, 1);
    phks__raw_mesh_release(&raw);
}
END_TEST

START_TEST(byte_order_mark_skipped)
{
    static const char obj[] = "\xEF\xBB\xBFv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    static const char off[] = "\xEF\xBB\xBFOFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    phks__raw_mesh raw;
    ck_assert_int_eq(READ(phks__read_obj, obj, &raw), PHKS_OK);
    ck_assert_uint_eq(raw.vertex_count, 3);
    phks__raw_mesh_release(&raw);
    phks_mesh *mesh;
    ck_assert_int_eq(phks_mesh_load_memory(off, sizeof off - 1, PHKS_FORMAT_AUTO,
                                           &mesh),
                     PHKS_OK);
    ck_assert_uint_eq(phks_mesh_vertex_count(mesh), 3);
    phks_mesh_free(mesh);
}
END_TEST

START_TEST(obj_errors)
{
    EXPECT_FAIL(phks__read_obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
                PHKS_ERROR_INDEX_OUT_OF_RANGE, "line 4");
    EXPECT_FAIL(phks__read_obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 4\n",
                PHKS_ERROR_INDEX_OUT_OF_RANGE, "line 5");
    EXPECT_FAIL(phks__read_obj, "v 0 0 0\nv 1 0 0\nf 1 2 -3\nv 0 1 0\n",
                PHKS_ERROR_INDEX_OUT_OF_RANGE, "line 3");
    EXPECT_FAIL(phks__read_obj, "v 0 0 0\nv 1 0 0\nf 1 2 99999999999\n",
                PHKS_ERROR_INDEX_OUT_OF_RANGE, "line 3");
    EXPECT_FAIL(phks__read_obj, "v 0 0 0\nv 1 NaN 0\nv 0 1 0\nf 1 2 3\n",
                PHKS_ERROR_NON_FINITE, "line 2");
    EXPECT_FAIL(phks__read_obj, "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n",
                PHKS_ERROR_PARSE, "line 2");
    EXPECT_FAIL(phks__read_obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n",
                PHKS_ERROR_PARSE, "line 4");
    EXPECT_FAIL(phks__read_obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/x 2 3\n",
                PHKS_ERROR_PARSE, "line 4");
    EXPECT_FAIL(phks__read_obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/1/1/1\n",
                PHKS_ERROR_PARSE, "line 4");
    EXPECT_FAIL(phks__read_obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",
                PHKS_ERROR_PARSE, "line 4");
    EXPECT_FAIL(phks__read_obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\n",
                PHKS_ERROR_NO_TRIANGLES, "no faces");
    EXPECT_FAIL(phks__read_obj, "", PHKS_ERROR_NO_TRIANGLES, "no faces");
}
END_TEST

/* ----------------------------------------------------------------- PLY */

typedef enum { ASCII, LITTLE, BIG } ply_mode;

static void put_value(bytes *b, ply_mode mode, const char *type, double v)
{
    if (mode == ASCII) {
        char text[64];
        snprintf(text, sizeof text, "%.17g ", v);
        put_text(b, text);
        return;
    }
    unsigned char c[8];
    size_t n;
    if (!strcmp(type, "char") || !strcmp(type, "int8")) {
        int8_t x = (int8_t)v;
        memcpy(c, &x, n = 1);
    } else if (!strcmp(type, "uchar") || !strcmp(type, "uint8")) {
        uint8_t x = (uint8_t)v;
        memcpy(c, &x, n = 1);
    } else if (!strcmp(type, "short") || !strcmp(type, "int16")) {
        int16_t x = (int16_t)v;
        memcpy(c, &x, n = 2);
    } else if (!strcmp(type, "ushort") || !strcmp(type, "uint16")) {
        uint16_t x = (uint16_t)v;
        memcpy(c, &x, n = 2);
    } else if (!strcmp(type, "int") || !strcmp(type, "int32")) {
        int32_t x = (int32_t)v;
        memcpy(c, &x, n = 4);
    } else if (!strcmp(type, "uint") || !strcmp(type, "uint32")) {
        uint32_t x = (uint32_t)v;
        memcpy(c, &x, n = 4);
    } else if (!strcmp(type, "float") || !strcmp(type, "float32")) {
        float x = (float)v;
        memcpy(c, &x, n = 4);
    } else {
        memcpy(c, &v, n = 8);
    }
    /* The tests run on little-endian hosts (x86-64, arm64). */
    if (mode == BIG)
        for (size_t i = 0; i < n / 2; i++) {
            unsigned char t = c[i];
            c[i] = c[n - 1 - i];
            c[n - 1 - i] = t;
        }
    put(b, c, n);
}

static void put_end(bytes *b, ply_mode mode)
{
    if (mode == ASCII)
        put_text(b, "\n");
}

/* A tetrahedron plus a quad, with properties of every type around the
 * ones we read and elements before and after. */
static bytes build_ply(ply_mode mode)
{
    bytes b = {0};
    put_text(&b, "ply\n");
    put_text(&b, mode == ASCII    ? "format ascii 1.0\n"
                 : mode == LITTLE ? "format binary_little_endian 1.0\n"
                                  : "format binary_big_endian 1.0\n");
    put_text(&b, "comment built by test_readers\n"
                 "obj_info nothing\n"
                 "element material 2\n"
                 "property list uchar uint16 ids\n"
                 "property float shininess\n"
                 "property list int double weights\n"
                 "element vertex 4\n"
                 "property char a\n"
                 "property uchar b\n"
                 "property double x\n"
                 "property short c\n"
                 "property ushort d\n"
                 "property float y\n"
                 "property int e\n"
                 "property uint f\n"
                 "property int16 z\n"
                 "property list ushort float normal\n"
                 "property float64 g\n"
                 "property uint8 h\n"
                 "property int8 i\n"
                 "property uint16 j\n"
                 "property int32 k\n"
                 "property uint32 l\n"
                 "property float32 m\n"
                 "element face 5\n"
                 "property uchar flags\n"
                 "property list uint int vertex_indices\n"
                 "property list uchar float texcoord\n"
                 "property int8 last\n"
                 "element edge 2\n"
                 "property int vertex1\n"
                 "property int32 vertex2\n"
                 "property list uint8 uint8 extra\n"
                 "element nothing 3\n"
                 "end_header\n");
    for (int r = 0; r < 2; r++) {
        put_value(&b, mode, "uchar", 2);
        put_value(&b, mode, "uint16", 7);
        put_value(&b, mode, "uint16", 65535);
        put_value(&b, mode, "float", 0.5);
        put_value(&b, mode, "int", 3);
        put_value(&b, mode, "double", 1.25);
        put_value(&b, mode, "double", -2);
        put_value(&b, mode, "double", 1e300);
        put_end(&b, mode);
    }
    for (int v = 0; v < 4; v++) {
        put_value(&b, mode, "char", -5);
        put_value(&b, mode, "uchar", 200);
        put_value(&b, mode, "double", tetra_xyz[3 * v]);
        put_value(&b, mode, "short", -300);
        put_value(&b, mode, "ushort", 60000);
        put_value(&b, mode, "float", tetra_xyz[3 * v + 1]);
        put_value(&b, mode, "int", -70000);
        put_value(&b, mode, "uint", 4000000000.0);
        put_value(&b, mode, "int16", tetra_xyz[3 * v + 2]);
        put_value(&b, mode, "ushort", 3);
        for (int k = 0; k < 3; k++)
            put_value(&b, mode, "float", 0.25 * k);
        put_value(&b, mode, "float64", 1e-300);
        put_value(&b, mode, "uint8", 1);
        put_value(&b, mode, "int8", -1);
        put_value(&b, mode, "uint16", 2);
        put_value(&b, mode, "int32", -3);
        put_value(&b, mode, "uint32", 4);
        put_value(&b, mode, "float32", 5);
        put_end(&b, mode);
    }
    for (int f = 0; f < 5; f++) {
        put_value(&b, mode, "uchar", 1);
        put_value(&b, mode, "uint", f < 4 ? 3 : 4);
        for (int k = 0; k < (f < 4 ? 3 : 4); k++)
            put_value(&b, mode, "int", f < 4 ? (double)tetra_tri[3 * f + k] : k);
        put_value(&b, mode, "uchar", 6);
        for (int k = 0; k < 6; k++)
            put_value(&b, mode, "float", k);
        put_value(&b, mode, "int8", -1);
        put_end(&b, mode);
    }
    for (int e = 0; e < 2; e++) {
        put_value(&b, mode, "int", e);
        put_value(&b, mode, "int32", e + 1);
        put_value(&b, mode, "uint8", 2);
        put_value(&b, mode, "uint8", 9);
        put_value(&b, mode, "uint8", 9);
        put_end(&b, mode);
    }
    return b;
}

static void expect_built_ply(const phks__raw_mesh *raw)
{
    static const uint32_t tri[18] = {0, 2, 1, 0, 1, 3, 0, 3, 2,
                                     1, 2, 3, 0, 1, 2, 0, 2, 3};
    ck_assert_uint_eq(raw->vertex_count, 4);
    for (size_t v = 0; v < 4; v++)
        expect_vertex(raw, v, tetra_xyz[3 * v], tetra_xyz[3 * v + 1],
                      tetra_xyz[3 * v + 2]);
    expect_triangles(raw, tri, 6);
}

START_TEST(ply_every_encoding)
{
    for (ply_mode mode = ASCII; mode <= BIG; mode++) {
        bytes b = build_ply(mode);
        phks__raw_mesh raw;
        phks_status st = run_reader(phks__read_ply, b.p, b.n, &raw);
        ck_assert_msg(st == PHKS_OK, "mode %d: %s", (int)mode,
                      phks_last_error_message());
        expect_built_ply(&raw);
        phks__raw_mesh_release(&raw);
        /* every shorter prefix fails cleanly */
        for (size_t n = 0; n < b.n; n += 1 + n / 64) {
            st = run_reader(phks__read_ply, b.p, n, &raw);
            if (st == PHKS_OK && mode != ASCII)
                ck_abort_msg("prefix %zu read", n);
            phks__raw_mesh_release(&raw);
        }
        free(b.p);
    }
}
END_TEST

START_TEST(ply_ascii_layouts)
{
    phks__raw_mesh raw;
    ck_assert_int_eq(READ(phks__read_ply, tetra_ply, &raw), PHKS_OK);
    expect_tetra(&raw);
    phks__raw_mesh_release(&raw);

    static const char faces_first[] =
        "ply\r\nformat ascii 1.0\r\ncomment faces come first\r\n"
        "element face 4\r\nproperty list uint8 uint32 vertex_index\r\n"
        "element vertex 4\r\nproperty double z\r\nproperty double y\r\n"
        "property double x\r\nend_header\r\n"
        "3 0 2 1\r\n3 0 1 3\r\n3   0 3 2\r\n3 1 2 3\r\n"
        "0 0 0\r\n0 0 1.5\r\n0 2.25 0\r\n3 0\r\n0\r\n";
    ck_assert_int_eq(READ(phks__read_ply, faces_first, &raw), PHKS_OK);
    expect_tetra(&raw);
    phks__raw_mesh_release(&raw);

    /* an element without properties and a large count costs nothing */
    static const char empty_element[] =
        "ply\nformat binary_little_endian 1.0\nelement empty 4000000000\n"
        "element vertex 3\nproperty uchar x\nproperty uchar y\nproperty uchar z\n"
        "element face 1\nproperty list uchar uchar vertex_indices\nend_header\n"
        "\0\0\0\1\0\0\0\1\0\3\0\1\2";
    ck_assert_int_eq(READ(phks__read_ply, empty_element, &raw), PHKS_OK);
    ck_assert_uint_eq(raw.vertex_count, 3);
    ck_assert_uint_eq(raw.triangle_count, 1);
    expect_vertex(&raw, 2, 0, 1, 0);
    phks__raw_mesh_release(&raw);
}
END_TEST

#define PLY_LE_HEADER                                                          \
    "ply\nformat binary_little_endian 1.0\nelement vertex 3\n"                 \
    "property float x\nproperty float y\nproperty float z\n"                   \
    "element face 1\nproperty list uchar int vertex_indices\nend_header\n"

/* The small binary file above, with one value changed. */
static bytes build_small_binary(int nan_vertex, int bad_index)
{
    bytes b = {0};
    put_text(&b, PLY_LE_HEADER);
    static const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    for (int i = 0; i < 9; i++)
        put_f32le(&b, i == nan_vertex ? NAN : xyz[i]);
    put(&b, "\3", 1);
    for (int k = 0; k < 3; k++)
        put_le32(&b, k == 2 && bad_index ? (uint32_t)bad_index : (uint32_t)k);
    return b;
}

START_TEST(ply_binary_errors)
{
    size_t header = strlen(PLY_LE_HEADER);
    char needle[64];
    phks__raw_mesh raw;

    bytes b = build_small_binary(-1, 0);
    ck_assert_int_eq(run_reader(phks__read_ply, b.p, b.n, &raw), PHKS_OK);
    phks__raw_mesh_release(&raw);
    /* cut: the header's counts no longer fit */
    expect_fail_n(phks__read_ply, b.p, b.n - 2, PHKS_ERROR_TOO_LARGE, "line 7");
    free(b.p);
    /* cut inside a quad's index list, which the counts do not foresee */
    static const char quad_cut[] =
        "ply\nformat binary_little_endian 1.0\nelement vertex 4\n"
        "property uchar x\nproperty uchar y\nproperty uchar z\n"
        "element face 1\nproperty list uchar uchar vertex_indices\nend_header\n"
        "\0\0\0\1\0\0\1\1\0\0\1\0\4\0\1\2";
    EXPECT_FAIL(phks__read_ply, quad_cut, PHKS_ERROR_TRUNCATED, "byte offset");

    b = build_small_binary(4, 0); /* y of vertex 1 */
    snprintf(needle, sizeof needle, "byte offset %zu", header + 16);
    expect_fail_n(phks__read_ply, b.p, b.n, PHKS_ERROR_NON_FINITE, needle);
    free(b.p);

    b = build_small_binary(-1, 3);
    snprintf(needle, sizeof needle, "byte offset %zu", header + 36 + 1 + 8);
    expect_fail_n(phks__read_ply, b.p, b.n, PHKS_ERROR_INDEX_OUT_OF_RANGE, needle);
    free(b.p);

    b = build_small_binary(-1, -1); /* index 0xffffffff read as int: -1 */
    expect_fail_n(phks__read_ply, b.p, b.n, PHKS_ERROR_INDEX_OUT_OF_RANGE, needle);
    free(b.p);

    /* a count the data cannot hold, refused before allocating */
    static const char huge[] =
        "ply\nformat binary_big_endian 1.0\nelement vertex 1000000000\n"
        "property float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
        "0123456789";
    EXPECT_FAIL(phks__read_ply, huge, PHKS_ERROR_TOO_LARGE, "line 3");
    static const char huge_list[] =
        "ply\nformat binary_big_endian 1.0\nelement vertex 3\n"
        "property uchar x\nproperty uchar y\nproperty uchar z\n"
        "element face 1\nproperty list uint int vertex_indices\nend_header\n"
        "\0\0\0\1\0\0\0\1\0\xff\xff\xff\xff\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0";
    EXPECT_FAIL(phks__read_ply, huge_list, PHKS_ERROR_TRUNCATED, "byte offset");
    static const char negative_list[] =
        "ply\nformat binary_big_endian 1.0\nelement vertex 3\n"
        "property uchar x\nproperty uchar y\nproperty uchar z\n"
        "element face 1\nproperty list int int vertex_indices\nend_header\n"
        "\0\0\0\1\0\0\0\1\0\xff\xff\xff\xff\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0";
    EXPECT_FAIL(phks__read_ply, negative_list, PHKS_ERROR_PARSE, "byte offset");
}
END_TEST

START_TEST(ply_header_errors)
{
    EXPECT_FAIL(phks__read_ply, "plx\n", PHKS_ERROR_PARSE, "line 1");
    EXPECT_FAIL(phks__read_ply, "ply\nformat ascii 1.0\nelement vertex 3\n",
                PHKS_ERROR_TRUNCATED, "line 4");
    EXPECT_FAIL(phks__read_ply, "ply\nformat ebcdic 1.0\nend_header\n",
                PHKS_ERROR_PARSE, "line 2");
    EXPECT_FAIL(phks__read_ply, "ply\nformat ascii 2.0\nend_header\n",
                PHKS_ERROR_PARSE, "line 2");
    EXPECT_FAIL(phks__read_ply, "ply\nformat ascii 1.0\nproperty float x\n",
                PHKS_ERROR_PARSE, "line 3");
    EXPECT_FAIL(phks__read_ply,
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\n",
                PHKS_ERROR_PARSE, "line 4");
    EXPECT_FAIL(phks__read_ply,
                "ply\nformat ascii 1.0\nelement vertex 1\n"
                "property list float int x\n",
                PHKS_ERROR_PARSE, "line 4");
    EXPECT_FAIL(phks__read_ply,
                "ply\nformat ascii 1.0\nelement vertex -1\n", PHKS_ERROR_PARSE,
                "line 3");
    EXPECT_FAIL(phks__read_ply,
                "ply\nformat ascii 1.0\nelement vertex 4294967295\n",
                PHKS_ERROR_TOO_LARGE, "line 3");
    EXPECT_FAIL(phks__read_ply,
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                "property float y\nelement face 0\n"
                "property list uchar int vertex_indices\nend_header\n0 0\n",
                PHKS_ERROR_PARSE, "line 3");
    EXPECT_FAIL(phks__read_ply,
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                "property float y\nproperty float z\nelement face 1\n"
                "property list uchar float vertex_indices\nend_header\n",
                PHKS_ERROR_PARSE, "line 8");
    EXPECT_FAIL(phks__read_ply,
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                "property float y\nproperty float z\nelement face 1\n"
                "property int vertex_indices\nend_header\n",
                PHKS_ERROR_PARSE, "line 8");
    EXPECT_FAIL(phks__read_ply,
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                "property float y\nproperty float z\nelement face 1\n"
                "property uchar flags\nend_header\n",
                PHKS_ERROR_PARSE, "line 7");
    EXPECT_FAIL(phks__read_ply,
                "ply\nelement vertex 1\nproperty float x\nend_header\n",
                PHKS_ERROR_PARSE, "line 4");
    EXPECT_FAIL(phks__read_ply,
                "ply\nformat ascii 1.0\nbogus line\nend_header\n",
                PHKS_ERROR_PARSE, "line 3");
    EXPECT_FAIL(phks__read_ply,
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                "property float y\nproperty float z\nend_header\n"
                "0 0 0\n1 0 0\n0 1 0\n",
                PHKS_ERROR_NO_TRIANGLES, "no faces");
}
END_TEST

#define PLY_ASCII_HEADER                                                       \
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"              \
    "property float y\nproperty float z\nelement face 1\n"                     \
    "property list uchar int vertex_indices\nend_header\n"

START_TEST(ply_ascii_data_errors)
{
    EXPECT_FAIL(phks__read_ply, PLY_ASCII_HEADER "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n",
                PHKS_ERROR_NON_FINITE, "line 11");
    EXPECT_FAIL(phks__read_ply, PLY_ASCII_HEADER "0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n",
                PHKS_ERROR_PARSE, "line 11");
    EXPECT_FAIL(phks__read_ply, PLY_ASCII_HEADER "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
                PHKS_ERROR_INDEX_OUT_OF_RANGE, "line 13");
    EXPECT_FAIL(phks__read_ply, PLY_ASCII_HEADER "0 0 0\n1 0 0\n0 1 0\n-3 0 1 2\n",
                PHKS_ERROR_PARSE, "line 13");
    EXPECT_FAIL(phks__read_ply, PLY_ASCII_HEADER "0 0 0\n1 0 0\n0 1 0\n2 0 1    ",
                PHKS_ERROR_PARSE, "line 13");
    EXPECT_FAIL(phks__read_ply, PLY_ASCII_HEADER "0 0 0\n1 0 0\n0 1 0\n3 0 1    ",
                PHKS_ERROR_TRUNCATED, "line 13");
}
END_TEST

/* ----------------------------------------------------------------- STL */

static bytes build_binary_stl(const char *header, const float (*corners)[3],
                              uint32_t facets)
{
    bytes b = {0};
    char h[80] = {0};
    memcpy(h, header, strlen(header) < 80 ? strlen(header) : 80);
    put(&b, h, 80);
    put_le32(&b, facets);
    for (uint32_t f = 0; f < facets; f++) {
        for (int k = 0; k < 3; k++)
            put_f32le(&b, 0);
        for (int k = 0; k < 3; k++)
            for (int d = 0; d < 3; d++)
                put_f32le(&b, corners[3 * f + k][d]);
        put(&b, "\0\0", 2);
    }
    return b;
}

static const float two_corners[6][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0},
                                        {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};

START_TEST(stl_ascii)
{
    phks__raw_mesh raw;
    ck_assert_int_eq(READ(phks__read_stl, two_stl, &raw), PHKS_OK);
    expect_two_triangles(&raw);
    phks__raw_mesh_release(&raw);

    /* shouting, two solids, a quad loop, -0 welded to 0, no final endsolid */
    static const char loud[] =
        "SOLID first\nFACET NORMAL nan nan nan\nOUTER LOOP\n"
        "VERTEX -0 0 0\nVERTEX 1 0 0\nVERTEX 0 1e0 0\nENDLOOP\nENDFACET\n"
        "ENDSOLID first\n"
        "solid second\nfacet normal 0 0 1\nouter loop\n"
        "vertex 1 0 0\nvertex 2 0 0\nvertex 1 1 0\nvertex 0.0 1 -0.0\n"
        "endloop\nendfacet\n";
    static const uint32_t tri[9] = {0, 1, 2, 1, 3, 4, 1, 4, 2};
    static const uint32_t origin[5] = {0, 1, 2, 4, 5};
    ck_assert_int_eq(READ(phks__read_stl, loud, &raw), PHKS_OK);
    ck_assert_uint_eq(raw.vertex_count, 5);
    expect_triangles(&raw, tri, 3);
    for (size_t v = 0; v < 5; v++)
        ck_assert_uint_eq(raw.vertex_origin[v], origin[v]);
    ck_assert(!signbit(raw.xyz[0]));
    phks__raw_mesh_release(&raw);
}
END_TEST

START_TEST(stl_binary)
{
    const char *headers[] = {"binary two triangles", "solid but binary", ""};
    for (int i = 0; i < 3; i++) {
        bytes b = build_binary_stl(headers[i], two_corners, 2);
        phks__raw_mesh raw;
        phks_status st = run_reader(phks__read_stl, b.p, b.n, &raw);
        ck_assert_msg(st == PHKS_OK, "%s", phks_last_error_message());
        expect_two_triangles(&raw);
        phks__raw_mesh_release(&raw);
        free(b.p);
    }
}
END_TEST

/* A grid of n x n squares as 2 n^2 facets: (n+1)^2 vertices after welding,
 * in a scan order that lets the origins be checked. */
START_TEST(stl_welding_many)
{
    const uint32_t n = 300, facets = 2 * n * n;
    float (*corners)[3] = malloc(3 * (size_t)facets * sizeof *corners);
    ck_assert_ptr_nonnull(corners);
    size_t c = 0;
    for (uint32_t i = 0; i < n; i++)
        for (uint32_t j = 0; j < n; j++) {
            float x0 = (float)i * 0.1f, x1 = (float)(i + 1) * 0.1f;
            float y0 = (float)j * 0.1f, y1 = (float)(j + 1) * 0.1f;
            const float q[6][3] = {{x0, y0, 0}, {x1, y0, 0}, {x1, y1, 0},
                                   {x0, y0, 0}, {x1, y1, 0}, {x0, y1, 0}};
            memcpy(corners + c, q, sizeof q);
            c += 6;
        }
    bytes b = build_binary_stl("grid", (const float(*)[3])corners, facets);
    phks__raw_mesh raw;
    ck_assert_int_eq(run_reader(phks__read_stl, b.p, b.n, &raw), PHKS_OK);
    ck_assert_uint_eq(raw.vertex_count, (size_t)(n + 1) * (n + 1));
    ck_assert_uint_eq(raw.triangle_count, facets);
    size_t wrong = 0; /* counted, as Check is slow at many assertions */
    for (size_t v = 0; v < raw.vertex_count; v++) {
        uint32_t o = raw.vertex_origin[v];
        const float *p = corners[o < 3 * facets ? o : 0];
        const double *q = raw.xyz + 3 * v;
        wrong += o >= 3 * facets || q[0] != p[0] || q[1] != p[1] || q[2] != p[2];
        wrong += v > 0 && o <= raw.vertex_origin[v - 1];
    }
    for (size_t k = 0; k < 3 * (size_t)facets; k++) {
        const double *p = raw.xyz + 3 * raw.triangles[k];
        wrong += p[0] != corners[k][0] || p[1] != corners[k][1] ||
                 p[2] != corners[k][2];
    }
    ck_assert_uint_eq(wrong, 0);
    phks__raw_mesh_release(&raw);
    free(b.p);
    free(corners);
}
END_TEST

START_TEST(stl_errors)
{
    char needle[64];
    bytes b = build_binary_stl("binary", two_corners, 2);
    b.p[80] = 10; /* declares 10 facets, holds 2 */
    expect_fail_n(phks__read_stl, b.p, b.n, PHKS_ERROR_TOO_LARGE, "byte offset 80");
    b.p[80] = 0xff, b.p[81] = 0xff, b.p[82] = 0xff, b.p[83] = 0xff;
    expect_fail_n(phks__read_stl, b.p, b.n, PHKS_ERROR_TOO_LARGE, "byte offset 80");
    b.p[80] = 0, b.p[81] = 0, b.p[82] = 0, b.p[83] = 0;
    expect_fail_n(phks__read_stl, b.p, 84, PHKS_ERROR_NO_TRIANGLES, "byte offset 80");
    expect_fail_n(phks__read_stl, b.p, 60, PHKS_ERROR_TRUNCATED, "byte offset 60");
    free(b.p);

    float corners[6][3];
    memcpy(corners, two_corners, sizeof corners);
    corners[4][2] = INFINITY; /* facet 1, corner 1, z */
    b = build_binary_stl("binary", (const float(*)[3])corners, 2);
    snprintf(needle, sizeof needle, "byte offset %d", 84 + 50 + 12 + 12 + 8);
    expect_fail_n(phks__read_stl, b.p, b.n, PHKS_ERROR_NON_FINITE, needle);
    free(b.p);

    EXPECT_FAIL(phks__read_stl,
                "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
                "vertex 1 nan 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid\n",
                PHKS_ERROR_NON_FINITE, "line 5");
    EXPECT_FAIL(phks__read_stl,
                "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
                "vertex 1 0 zz\nvertex 0 1 0\nendloop\nendfacet\nendsolid\n",
                PHKS_ERROR_PARSE, "line 5");
    EXPECT_FAIL(phks__read_stl,
                "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
                "vertex 1 0 0\nendloop\nendfacet\nendsolid\n",
                PHKS_ERROR_PARSE, "line 6");
    EXPECT_FAIL(phks__read_stl,
                "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
                "vertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nfacet normal\n"
                "outer loop\nvertex 0 0 0\n",
                PHKS_ERROR_TRUNCATED, "line 12");
    EXPECT_FAIL(phks__read_stl,
                "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
                "vertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nfoo\n",
                PHKS_ERROR_PARSE, "line 9");
    EXPECT_FAIL(phks__read_stl, "solid empty\nendsolid empty\n",
                PHKS_ERROR_NO_TRIANGLES, "no facets");
}
END_TEST

/* -------------------------------------------------------------- loading */

static char temp_dir[64];

static void make_temp_dir(void)
{
    snprintf(temp_dir, sizeof temp_dir, "/tmp/phks-readers-XXXXXX");
    ck_assert_ptr_nonnull(mkdtemp(temp_dir));
}

static void remove_temp_dir(void)
{
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", temp_dir);
    ck_assert_int_eq(system(cmd), 0);
}

static char *temp_path(const char *name)
{
    static char path[256];
    snprintf(path, sizeof path, "%s/%s", temp_dir, name);
    return path;
}

static void write_file(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    ck_assert_ptr_nonnull(f);
    ck_assert_uint_eq(fwrite(data, 1, n, f), n);
    ck_assert_int_eq(fclose(f), 0);
}

static void write_gzip(const char *path, const void *data, size_t n)
{
    gzFile g = gzopen(path, "wb");
    ck_assert_ptr_nonnull(g);
    ck_assert_int_eq(gzwrite(g, data, (unsigned)n), (int)n);
    ck_assert_int_eq(gzclose(g), Z_OK);
}

static unsigned char *slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    ck_assert_ptr_nonnull(f);
    unsigned char *data = NULL;
    size_t cap = 0;
    *n = 0;
    for (;;) {
        if (*n == cap) {
            cap = cap ? 2 * cap : 1 << 16;
            data = realloc(data, cap);
            ck_assert_ptr_nonnull(data);
        }
        size_t got = fread(data + *n, 1, cap - *n, f);
        *n += got;
        if (got == 0)
            break;
    }
    fclose(f);
    return data;
}

/* Takes the mesh by address: the status argument is evaluated (the load
 * runs) in an unspecified order with the other arguments. */
static void expect_tetra_mesh(phks_status st, phks_mesh **out)
{
    phks_mesh *mesh = *out;
    ck_assert_msg(st == PHKS_OK, "%s", phks_last_error_message());
    ck_assert_uint_eq(phks_mesh_vertex_count(mesh), 4);
    ck_assert_uint_eq(phks_mesh_triangle_count(mesh), 4);
    const double *xyz = phks_mesh_vertices(mesh);
    for (int i = 0; i < 12; i++)
        ck_assert_double_eq(xyz[i], tetra_xyz[i]);
    phks_mesh_free(mesh);
}

START_TEST(load_memory_detects_format)
{
    const char *texts[] = {tetra_off, tetra_obj, tetra_ply};
    phks_format formats[] = {PHKS_FORMAT_OFF, PHKS_FORMAT_OBJ, PHKS_FORMAT_PLY};
    for (int i = 0; i < 3; i++) {
        phks_mesh *mesh;
        expect_tetra_mesh(phks_mesh_load_memory(texts[i], strlen(texts[i]),
                                                PHKS_FORMAT_AUTO, &mesh),
                          &mesh);
        expect_tetra_mesh(phks_mesh_load_memory(texts[i], strlen(texts[i]),
                                                formats[i], &mesh),
                          &mesh);
    }
    for (ply_mode mode = ASCII; mode <= BIG; mode++) {
        bytes b = build_ply(mode);
        phks_mesh *mesh;
        ck_assert_int_eq(phks_mesh_load_memory(b.p, b.n, PHKS_FORMAT_AUTO, &mesh),
                         PHKS_OK);
        ck_assert_uint_eq(phks_mesh_triangle_count(mesh), 6);
        phks_mesh_free(mesh);
        free(b.p);
    }
    const char *headers[] = {"binary", "solid but binary"};
    for (int i = 0; i < 2; i++) {
        bytes b = build_binary_stl(headers[i], two_corners, 2);
        phks_mesh *mesh;
        ck_assert_int_eq(phks_mesh_load_memory(b.p, b.n, PHKS_FORMAT_AUTO, &mesh),
                         PHKS_OK);
        ck_assert_uint_eq(phks_mesh_vertex_count(mesh), 4);
        ck_assert_uint_eq(phks_mesh_vertex_origin(mesh)[3], 4);
        phks_mesh_free(mesh);
        free(b.p);
    }
    phks_mesh *mesh;
    ck_assert_int_eq(phks_mesh_load_memory(two_stl, strlen(two_stl),
                                           PHKS_FORMAT_AUTO, &mesh),
                     PHKS_OK);
    ck_assert_uint_eq(phks_mesh_vertex_count(mesh), 4);
    phks_mesh_free(mesh);
}
END_TEST

START_TEST(load_memory_errors)
{
    static int dummy;
    phks_mesh *mesh = (phks_mesh *)&dummy;
    ck_assert_int_eq(phks_mesh_load_memory("garbage", 7, PHKS_FORMAT_AUTO, &mesh),
                     PHKS_ERROR_UNKNOWN_FORMAT);
    ck_assert_ptr_null(mesh);
    ck_assert_int_eq(phks_mesh_load_memory("", 0, PHKS_FORMAT_AUTO, &mesh),
                     PHKS_ERROR_UNKNOWN_FORMAT);
    ck_assert_int_eq(phks_mesh_load_memory(tetra_off, strlen(tetra_off),
                                           PHKS_FORMAT_PLY, &mesh),
                     PHKS_ERROR_PARSE);
    ck_assert_int_eq(phks_mesh_load_memory(NULL, 4, PHKS_FORMAT_AUTO, &mesh),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_mesh_load_memory(tetra_off, 4, PHKS_FORMAT_AUTO, NULL),
                     PHKS_ERROR_INVALID_ARGUMENT);
    mesh = (phks_mesh *)&temp_dir;
    ck_assert_int_eq(phks_mesh_load_memory(tetra_off, 4, (phks_format)9, &mesh),
                     PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_ptr_null(mesh);
    /* a reader's success and the mesh builder's refusal */
    static const char flat[] = "OFF\n3 1 0\n0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n";
    ck_assert_int_eq(phks_mesh_load_memory(flat, strlen(flat), PHKS_FORMAT_AUTO,
                                           &mesh),
                     PHKS_ERROR_ZERO_AREA);
    ck_assert_ptr_null(mesh);
}
END_TEST

START_TEST(load_files)
{
    make_temp_dir();
    phks_mesh *mesh;

    /* by name, any case, gzipped or not; unknown names by content */
    write_file(temp_path("tetra.off"), tetra_off, strlen(tetra_off));
    expect_tetra_mesh(phks_mesh_load(temp_path("tetra.off"), &mesh), &mesh);
    write_gzip(temp_path("tetra.PLY.GZ"), tetra_ply, strlen(tetra_ply));
    expect_tetra_mesh(phks_mesh_load(temp_path("tetra.PLY.GZ"), &mesh), &mesh);
    write_gzip(temp_path("tetra.mesh"), tetra_obj, strlen(tetra_obj));
    expect_tetra_mesh(phks_mesh_load(temp_path("tetra.mesh"), &mesh), &mesh);
    write_file(temp_path("tetra"), tetra_obj, strlen(tetra_obj));
    expect_tetra_mesh(phks_mesh_load(temp_path("tetra"), &mesh), &mesh);

    /* the name wins over the content */
    write_file(temp_path("tetra.stl"), tetra_off, strlen(tetra_off));
    ck_assert_int_ne(phks_mesh_load(temp_path("tetra.stl"), &mesh), PHKS_OK);
    expect_message("byte offset");

    /* gzip from memory, and two concatenated members as gunzip reads them */
    size_t n;
    unsigned char *gz = slurp(temp_path("tetra.PLY.GZ"), &n);
    expect_tetra_mesh(phks_mesh_load_memory(gz, n, PHKS_FORMAT_AUTO, &mesh), &mesh);
    free(gz);
    size_t half = strlen(tetra_off) / 2, n1, n2;
    write_gzip(temp_path("a.gz"), tetra_off, half);
    write_gzip(temp_path("b.gz"), tetra_off + half, strlen(tetra_off) - half);
    unsigned char *a = slurp(temp_path("a.gz"), &n1);
    unsigned char *b = slurp(temp_path("b.gz"), &n2);
    a = realloc(a, n1 + n2);
    memcpy(a + n1, b, n2);
    expect_tetra_mesh(phks_mesh_load_memory(a, n1 + n2, PHKS_FORMAT_AUTO, &mesh),
                      &mesh);

    /* truncated gzip, and a broken checksum */
    write_file(temp_path("cut.off.gz"), a, n1 - 5);
    ck_assert_int_eq(phks_mesh_load(temp_path("cut.off.gz"), &mesh),
                     PHKS_ERROR_TRUNCATED);
    expect_message(temp_path("cut.off.gz"));
    expect_message("gzip");
    a[n1 - 8] ^= 0x55; /* the CRC-32 of the first member */
    write_file(temp_path("crc.off.gz"), a, n1);
    ck_assert_int_eq(phks_mesh_load(temp_path("crc.off.gz"), &mesh),
                     PHKS_ERROR_PARSE);
    expect_message("gzip");
    ck_assert_int_eq(phks_mesh_load_memory(a, n1, PHKS_FORMAT_OFF, &mesh),
                     PHKS_ERROR_PARSE);
    memset(a + 10, 0xff, n1 - 18); /* garbage deflate data */
    ck_assert_int_eq(phks_mesh_load_memory(a, n1, PHKS_FORMAT_OFF, &mesh),
                     PHKS_ERROR_PARSE);
    free(a);
    free(b);

    /* the message names the file and the line */
    static const char bad[] = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 inf 0\n3 0 1 2\n";
    write_file(temp_path("bad.off"), bad, strlen(bad));
    ck_assert_int_eq(phks_mesh_load(temp_path("bad.off"), &mesh),
                     PHKS_ERROR_NON_FINITE);
    char expected[300];
    snprintf(expected, sizeof expected, "%s: line 5: ", temp_path("bad.off"));
    ck_assert_msg(strncmp(phks_last_error_message(), expected, strlen(expected)) == 0,
                  "message \"%s\"", phks_last_error_message());

    /* files that cannot be read */
    mesh = (phks_mesh *)&temp_dir;
    ck_assert_int_eq(phks_mesh_load(temp_path("missing.off"), &mesh), PHKS_ERROR_IO);
    ck_assert_ptr_null(mesh);
    expect_message(temp_path("missing.off"));
    expect_message(strerror(ENOENT));
    ck_assert_int_eq(phks_mesh_load(temp_dir, &mesh), PHKS_ERROR_IO);
    expect_message(temp_dir);
    write_file(temp_path("empty.ply"), "", 0);
    ck_assert_int_eq(phks_mesh_load(temp_path("empty.ply"), &mesh), PHKS_ERROR_PARSE);
    ck_assert_int_eq(phks_mesh_load(NULL, &mesh), PHKS_ERROR_INVALID_ARGUMENT);
    ck_assert_int_eq(phks_mesh_load(temp_path("tetra.off"), NULL),
                     PHKS_ERROR_INVALID_ARGUMENT);
    remove_temp_dir();
}
END_TEST

/* ------------------------------------------------ allocation failures */

/* Fails the first, second, ... allocation, and every one after it, until
 * the load succeeds: every failure must say "out of memory" and leave
 * nothing allocated (the counting allocator of testutil.h). */
static void sweep_failures(const void *data, size_t size)
{
    phks_allocator counting = {count_malloc, count_realloc, count_free, NULL};
    ck_assert_int_eq(phks_set_allocator(&counting), PHKS_OK);
    alloc_fail_rest = true;
    for (size_t budget = 0;; budget++) {
        ck_assert_uint_lt(budget, 1000);
        alloc_calls = 0;
        alloc_fail_at = (long)budget;
        alloc_live = 0;
        phks_mesh *mesh;
        phks_status st = phks_mesh_load_memory(data, size, PHKS_FORMAT_AUTO, &mesh);
        if (st == PHKS_OK) {
            phks_mesh_free(mesh);
            ck_assert_uint_eq(alloc_live, 0);
            break;
        }
        ck_assert_msg(st == PHKS_ERROR_OUT_OF_MEMORY, "budget %zu: %s", budget,
                      phks_last_error_message());
        ck_assert_uint_eq(alloc_live, 0);
        ck_assert_ptr_null(mesh);
    }
    alloc_fail_at = -1;
    alloc_fail_rest = false;
    phks_set_allocator(NULL);
}

START_TEST(allocation_failures)
{
    sweep_failures(tetra_off, strlen(tetra_off));
    sweep_failures(tetra_obj, strlen(tetra_obj));
    sweep_failures(two_stl, strlen(two_stl));
    for (ply_mode mode = ASCII; mode <= BIG; mode++) {
        bytes b = build_ply(mode);
        sweep_failures(b.p, b.n);
        free(b.p);
    }
    bytes b = build_binary_stl("binary", two_corners, 2);
    sweep_failures(b.p, b.n);
    free(b.p);
    make_temp_dir();
    write_gzip(temp_path("t.gz"), tetra_off, strlen(tetra_off));
    size_t n;
    unsigned char *gz = slurp(temp_path("t.gz"), &n);
    sweep_failures(gz, n);
    free(gz);
    remove_temp_dir();
}
END_TEST

/* ---------------------------------------------------- hostile mutations */

static void mutate_and_load(const unsigned char *data, size_t size,
                            uint64_t *state, int rounds)
{
    static const char junk[] = "0123456789-+.eE \n\r#/\\naninf\xff";
    for (int r = 0; r < rounds; r++) {
        size_t n = size;
        unsigned char *m = malloc(size + 16);
        ck_assert_ptr_nonnull(m);
        memcpy(m, data, size);
        int edits = 1 + (int)(4 * test_random(state));
        for (int e = 0; e < edits; e++) {
            size_t at = (size_t)(test_random(state) * (double)n);
            double kind = test_random(state);
            if (kind < 0.5 && at < n)
                m[at] = (unsigned char)junk[(int)(test_random(state) * (sizeof junk - 1))];
            else if (kind < 0.7 && at < n)
                m[at] = (unsigned char)(256 * test_random(state));
            else if (kind < 0.85)
                n = at; /* cut */
            else if (at < n)
                m[at] ^= (unsigned char)(1u << (int)(8 * test_random(state)));
        }
        unsigned char *exact = malloc(n ? n : 1);
        memcpy(exact, m, n);
        free(m);
        for (phks_format f = PHKS_FORMAT_AUTO; f <= PHKS_FORMAT_STL; f++) {
            phks_mesh *mesh;
            phks_status st = phks_mesh_load_memory(exact, n, f, &mesh);
            if (st < PHKS_OK || st > PHKS_ERROR_SOLVER ||
                (st == PHKS_OK) != (mesh != NULL))
                ck_abort_msg("status %d, mesh %p", (int)st, (void *)mesh);
            phks_mesh_free(mesh);
        }
        free(exact);
    }
}

START_TEST(hostile_mutations)
{
    uint64_t state = 7;
    const char *texts[] = {tetra_off, tetra_obj, tetra_ply, two_stl};
    for (int i = 0; i < 4; i++)
        mutate_and_load((const unsigned char *)texts[i], strlen(texts[i]), &state,
                        1500);
    for (ply_mode mode = ASCII; mode <= BIG; mode++) {
        bytes b = build_ply(mode);
        mutate_and_load(b.p, b.n, &state, 1500);
        free(b.p);
    }
    bytes b = build_binary_stl("solid", two_corners, 2);
    mutate_and_load(b.p, b.n, &state, 1500);
    free(b.p);
}
END_TEST

/* ------------------------------------------------------ shared meshes */

static unsigned char *read_maybe_gzip(const char *path, size_t *n)
{
    gzFile g = gzopen(path, "rb"); /* reads plain files too */
    ck_assert_ptr_nonnull(g);
    unsigned char *data = NULL;
    size_t cap = 0;
    *n = 0;
    for (;;) {
        if (*n == cap) {
            cap = cap ? 2 * cap : 1 << 20;
            data = realloc(data, cap);
            ck_assert_ptr_nonnull(data);
        }
        int got = gzread(g, data + *n, (unsigned)(cap - *n));
        ck_assert_int_ge(got, 0);
        if (got == 0)
            break;
        *n += (size_t)got;
    }
    gzclose(g);
    return data;
}

static reader_fn reader_for(const char *name)
{
    if (strstr(name, ".off"))
        return phks__read_off;
    if (strstr(name, ".obj"))
        return phks__read_obj;
    if (strstr(name, ".ply"))
        return phks__read_ply;
    return phks__read_stl;
}

/* Every mesh in MANIFEST.tsv (but the 1.6M-vertex one, kept for timing)
 * read raw with the counts the manifest gives; the scans and one PSB model
 * also loaded whole. */
START_TEST(shared_meshes)
{
    char *manifest = shared_mesh_path("MANIFEST.tsv");
    if (!manifest) {
        printf("test_readers: shared meshes absent, skipping shared_meshes\n");
        return;
    }
    FILE *f = fopen(manifest, "r");
    ck_assert_ptr_nonnull(f);
    char line[512];
    size_t files = 0;
    while (fgets(line, sizeof line, f)) {
        char name[256], cls[64];
        size_t vertices, faces;
        if (sscanf(line, "%255s %63s %zu %zu", name, cls, &vertices, &faces) != 4)
            continue; /* the heading */
        if (strncmp(name, "large/", 6) == 0)
            continue;
        char *path = shared_mesh_path(name);
        size_t n;
        unsigned char *data = read_maybe_gzip(path, &n);
        phks__raw_mesh raw;
        phks_status st = run_reader(reader_for(name), data, n, &raw);
        ck_assert_msg(st == PHKS_OK, "%s: %s", name, phks_last_error_message());
        ck_assert_msg(raw.vertex_count == vertices && raw.triangle_count == faces,
                      "%s: %zu vertices, %zu triangles; manifest %zu, %zu", name,
                      raw.vertex_count, raw.triangle_count, vertices, faces);
        phks__raw_mesh_release(&raw);
        free(data);

        if (strncmp(name, "scans/", 6) == 0 || strcmp(name, "psb/1.off.gz") == 0) {
            phks_mesh *mesh;
            st = phks_mesh_load(path, &mesh);
            ck_assert_msg(st == PHKS_OK, "%s", phks_last_error_message());
            ck_assert_uint_le(phks_mesh_vertex_count(mesh), vertices);
            ck_assert_uint_le(phks_mesh_triangle_count(mesh), faces);
            ck_assert_uint_gt(phks_mesh_triangle_count(mesh), faces * 99 / 100);
            if (strcmp(name, "psb/1.off.gz") == 0) {
                ck_assert_uint_eq(phks_mesh_vertex_count(mesh), 4706);
                ck_assert_uint_eq(phks_mesh_triangle_count(mesh), 9408);
            }
            phks_mesh_free(mesh);
        }
        free(path);
        files++;
    }
    fclose(f);
    free(manifest);
    ck_assert_uint_gt(files, 300);
}
END_TEST

/* ---------------------------------------------------------------- suite */

static Suite *readers_suite(void)
{
    Suite *s = suite_create("readers");
    TCase *scan = tcase_create("text_scan");
    tcase_add_test(scan, scan_parse_double_matches_strtod);
    tcase_add_test(scan, scan_parse_special_values);
    tcase_add_test(scan, scan_counts_lines);
    suite_add_tcase(s, scan);

    TCase *off = tcase_create("off");
    tcase_add_test(off, off_tetrahedron);
    tcase_add_test(off, off_header_forms);
    tcase_add_test(off, off_polygons_fan);
    tcase_add_test(off, off_errors);
    suite_add_tcase(s, off);

    TCase *obj = tcase_create("obj");
    tcase_add_test(obj, obj_tetrahedron);
    tcase_add_test(obj, obj_statements_ignored);
    tcase_add_test(obj, obj_polygons_negative_continuation);
    tcase_add_test(obj, obj_faces_before_vertices);
    tcase_add_test(obj, byte_order_mark_skipped);
    tcase_add_test(obj, obj_errors);
    suite_add_tcase(s, obj);

    TCase *ply = tcase_create("ply");
    tcase_add_test(ply, ply_every_encoding);
    tcase_add_test(ply, ply_ascii_layouts);
    tcase_add_test(ply, ply_binary_errors);
    tcase_add_test(ply, ply_header_errors);
    tcase_add_test(ply, ply_ascii_data_errors);
    suite_add_tcase(s, ply);

    TCase *stl = tcase_create("stl");
    tcase_add_test(stl, stl_ascii);
    tcase_add_test(stl, stl_binary);
    tcase_add_test(stl, stl_welding_many);
    tcase_add_test(stl, stl_errors);
    suite_add_tcase(s, stl);

    TCase *load = tcase_create("load");
    tcase_add_test(load, load_memory_detects_format);
    tcase_add_test(load, load_memory_errors);
    tcase_add_test(load, load_files);
    tcase_add_test(load, allocation_failures);
    tcase_add_test(load, hostile_mutations);
    tcase_add_test(load, shared_meshes);
    suite_add_tcase(s, load);
    return s;
}

int main(void)
{
    return run_suite(readers_suite());
}
