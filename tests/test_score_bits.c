/* test_score_bits.c - scores are the same bits in every build. Signatures
 * may differ between builds (the AVX2 + FMA kernels and the fast exp
 * round otherwise than the portable loops), scores may not: the scoring
 * code's SIMD and portable loops must agree to the bit. So the signatures
 * are committed, as blobs in tests/data/score_bits/, with a table of the
 * scores' bits made from them once; this test decodes the blobs and
 * requires every score of every build to be the table's. CI runs it in
 * the default build and in the portable one (-Dsimd=disabled; README's
 * test command), which so give the same bits.
 *
 * The blobs are four creatures' signatures (two kinds, two poses, and a
 * partial scan), once with the default options (verified matching, spin
 * images, the triangle quadrature), once with the heat vectors proposing
 * (PHKS_LOCAL_DESCRIPTOR_HEAT) and once with PHKS_MATCHING_NEAREST. A row
 * of the table is an ordered pair of blobs of the same options: the bits
 * of phks_score, of phks_score_nearest and of phks_match's score, as 16
 * hex digits, then the number of phks_match's rows marked verified and
 * each feature of the query's verified partner ('-': none).
 *
 * Made, blobs and table, by the default build on x86-64:
 *   build/tests/test_score_bits --write tests/data/score_bits
 * which computes the signatures anew; run it only when the blob format or
 * a score is meant to change, and commit both together. Scoring uses no
 * BLAS (OPENBLAS_NUM_THREADS does not matter to it). */
#include "partial.h"
#include "shapes.h"
#include "testutil.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { SHAPES = 4, GROUPS = 3, ROW_CHARS = 512 };

/* The blobs' names, without ".sig": GROUPS x SHAPES. */
static const char *const group_names[GROUPS] = {"verified", "heat",
                                                "nearest"};
static const char *const shape_names[SHAPES] = {
    "quadruped-pose1", "quadruped-pose3", "humanoid-pose1",
    "quadruped-pose3-scan"};

static const char *data_dir;

static char *path_of(const char *dir, const char *name, const char *ending)
{
    size_t n = strlen(dir) + strlen(name) + strlen(ending) + 2;
    char *path = malloc(n);
    if (path)
        snprintf(path, n, "%s/%s%s", dir, name, ending);
    return path;
}

/* The whole file, or NULL. */
static unsigned char *read_all(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    unsigned char *data = NULL;
    long n = fseek(f, 0, SEEK_END) == 0 ? ftell(f) : -1;
    if (n >= 0 && fseek(f, 0, SEEK_SET) == 0 && (data = malloc((size_t)n + 1)))
        if (fread(data, 1, (size_t)n, f) != (size_t)n) {
            free(data);
            data = NULL;
        }
    fclose(f);
    *size = (size_t)n;
    return data;
}

/* The name of the blob of shape s in group g, without ".sig". */
static void blob_name(size_t g, size_t s, char name[64])
{
    snprintf(name, 64, "%s-%s", group_names[g], shape_names[s]);
}

/* Blob `name`.sig of dir decoded, or NULL (with a message). */
static phks_signature *load(const char *dir, const char *name)
{
    char *path = path_of(dir, name, ".sig");
    size_t size = 0;
    unsigned char *blob = path ? read_all(path, &size) : NULL;
    phks_signature *sig = NULL;
    if (!blob || phks_signature_decode(blob, size, &sig) != PHKS_OK)
        fprintf(stderr, "%s: cannot read the signature\n", path);
    free(blob);
    free(path);
    return sig;
}

static uint64_t bits(double x)
{
    uint64_t u;
    memcpy(&u, &x, sizeof u);
    return u;
}

/* The number of phks_match's rows marked verified and each of a's
 * features' verified partner, "-" for none, from `at` on in row
 * (ROW_CHARS); its new end, or -1. */
static int print_partners(const phks_correspondence *pairs, size_t count,
                          size_t na, char *row, int at)
{
    size_t verified = 0;
    for (size_t r = 0; r < count; r++)
        verified += pairs[r].verified;
    at += snprintf(row + at, (size_t)(ROW_CHARS - at), " %zu ", verified);
    for (size_t r = 0; r < na && at < ROW_CHARS; r++)
        at += pairs[r].verified
                  ? snprintf(row + at, (size_t)(ROW_CHARS - at), "%s%" PRIu32,
                             r ? "," : "", pairs[r].feature_b)
                  : snprintf(row + at, (size_t)(ROW_CHARS - at), "%s-",
                             r ? "," : "");
    return at < ROW_CHARS ? at : -1;
}

/* The table's row of query a against entry b into row (ROW_CHARS);
 * false when a call fails. */
static bool score_row(const phks_signature *a, const phks_signature *b,
                      const char *name_a, const char *name_b, char *row)
{
    size_t na = phks_signature_feature_count(a), count;
    size_t room = na + phks_signature_feature_count(b);
    phks_correspondence *pairs = malloc(room * sizeof *pairs);
    double score, nearest, matched;
    bool ok = pairs && phks_score(a, b, &score) == PHKS_OK &&
              phks_score_nearest(a, b, &nearest) == PHKS_OK &&
              phks_match(a, b, pairs, room, &count, &matched) == PHKS_OK;
    if (ok) {
        int at = snprintf(row, ROW_CHARS,
                          "%s %s %016" PRIx64 " %016" PRIx64 " %016" PRIx64,
                          name_a, name_b, bits(score), bits(nearest),
                          bits(matched));
        ok = at > 0 && at < ROW_CHARS &&
             print_partners(pairs, count, na, row, at) > 0;
    }
    free(pairs);
    return ok;
}

/* Calls row_to(context, row) for every row of the table made from the
 * blobs of dir, in order; false when a blob or a score fails. */
static bool each_row(const char *dir, bool (*row_to)(void *, const char *),
                     void *context)
{
    bool ok = true;
    for (size_t g = 0; g < GROUPS && ok; g++) {
        phks_signature *sig[SHAPES] = {0};
        char name[SHAPES][64];
        for (size_t s = 0; s < SHAPES; s++) {
            blob_name(g, s, name[s]);
            ok = ok && (sig[s] = load(dir, name[s]));
        }
        for (size_t q = 0; q < SHAPES * SHAPES && ok; q++) {
            size_t a = q / SHAPES, b = q % SHAPES;
            char row[ROW_CHARS];
            ok = score_row(sig[a], sig[b], name[a], name[b], row) &&
                 row_to(context, row);
        }
        for (size_t s = 0; s < SHAPES; s++)
            phks_signature_free(sig[s]);
    }
    return ok;
}

/* ---- the check: every row of the committed table, in order */

typedef struct table_reader {
    FILE *f;
    size_t rows, wrong;
} table_reader;

/* The table's next row (past the comment lines), without its newline. */
static bool next_row(FILE *f, char *row)
{
    while (fgets(row, ROW_CHARS, f))
        if (row[0] != '#') {
            row[strcspn(row, "\n")] = 0;
            return true;
        }
    return false;
}

static bool compare_row(void *context, const char *row)
{
    table_reader *t = context;
    char want[ROW_CHARS];
    t->rows++;
    if (!next_row(t->f, want))
        want[0] = 0;
    if (strcmp(row, want)) {
        fprintf(stderr, "row %zu:\n  table %s\n  build %s\n", t->rows, want,
                row);
        t->wrong++;
    }
    return true;
}

START_TEST(scores_are_the_tables_bits)
{
    char *path = path_of(data_dir, "scores", ".txt");
    table_reader t = {fopen(path, "r"), 0, 0};
    ck_assert_msg(t.f, "%s: cannot open", path);
    ck_assert(each_row(data_dir, compare_row, &t));
    char extra[ROW_CHARS];
    ck_assert_msg(!next_row(t.f, extra), "the table has more rows: %s", extra);
    fclose(t.f);
    free(path);
    ck_assert_uint_eq(t.rows, GROUPS * SHAPES * SHAPES);
    ck_assert_msg(t.wrong == 0, "%zu of %zu rows differ from the table",
                  t.wrong, t.rows);
}
END_TEST

/* ---- --write: the blobs and the table anew */

/* Shape s of shape_names at the resolution of the tests' creatures. */
static int shape_of(size_t s, shape_mesh *out)
{
    static const unsigned kind[SHAPES] = {SHAPE_QUADRUPED, SHAPE_QUADRUPED,
                                          SHAPE_HUMANOID, SHAPE_QUADRUPED};
    static const unsigned pose[SHAPES] = {1, 3, 1, 3};
    double angles[SHAPE_MAX_JOINTS];
    shape_creature_pose(kind[s], pose[s], angles);
    if (shape_creature(kind[s], angles, 1, out))
        return -1;
    if (s + 1 < SHAPES)
        return 0;
    piece scan;
    int st = piece_partial_scan(out->xyz, out->vertex_count, out->triangles,
                                out->triangle_count, 1, &scan);
    shape_mesh_free(out);
    *out = (shape_mesh){scan.xyz, scan.vertex_count, scan.triangles,
                        scan.triangle_count};
    free(scan.source_vertex);
    return st;
}

static bool write_blob(const char *dir, size_t g, size_t s,
                       const phks_options *options)
{
    shape_mesh shape;
    if (shape_of(s, &shape))
        return false;
    phks_mesh *m = NULL;
    phks_signature *sig = NULL;
    bool ok = phks_mesh_create(shape.xyz, shape.vertex_count, shape.triangles,
                               shape.triangle_count, &m) == PHKS_OK &&
              phks_signature_compute(m, options, &sig) == PHKS_OK;
    size_t size = ok ? phks_signature_encoded_size(sig) : 0;
    unsigned char *blob = ok ? malloc(size) : NULL;
    char name[64];
    blob_name(g, s, name);
    char *path = path_of(dir, name, ".sig");
    FILE *f = blob && path ? fopen(path, "wb") : NULL;
    ok = f && phks_signature_encode(sig, blob, size, &size) == PHKS_OK &&
         fwrite(blob, 1, size, f) == size;
    ok = f && fclose(f) == 0 && ok;
    free(path);
    free(blob);
    phks_signature_free(sig);
    phks_mesh_free(m);
    shape_mesh_free(&shape);
    return ok;
}

static bool print_row(void *context, const char *row)
{
    return fprintf(context, "%s\n", row) > 0;
}

static int write_all(const char *dir)
{
    phks_options options[GROUPS];
    for (size_t g = 0; g < GROUPS; g++)
        phks_options_init(&options[g]);
    options[1].local_descriptor = PHKS_LOCAL_DESCRIPTOR_HEAT;
    options[2].matching = PHKS_MATCHING_NEAREST;
    bool ok = true;
    for (size_t g = 0; g < GROUPS; g++)
        for (size_t s = 0; s < SHAPES && ok; s++)
            ok = write_blob(dir, g, s, &options[g]);
    char *path = path_of(dir, "scores", ".txt");
    FILE *f = ok && path ? fopen(path, "w") : NULL;
    ok = f &&
         fprintf(f, "# The scores' bits of the blobs beside this file, made "
                    "with them by\n# test_score_bits --write "
                    "(tests/test_score_bits.c tells how to read it).\n") > 0 &&
         each_row(dir, print_row, f);
    ok = f && fclose(f) == 0 && ok;
    if (!ok)
        fprintf(stderr, "%s: cannot write the blobs and the table\n", dir);
    free(path);
    return ok ? 0 : 1;
}

int main(int argc, char **argv)
{
    if (argc == 3 && !strcmp(argv[1], "--write"))
        return write_all(argv[2]);
    if (argc != 2) {
        fprintf(stderr, "usage: %s [--write] DIR\n", argv[0]);
        return 2;
    }
    data_dir = argv[1];
    Suite *s = suite_create("score_bits");
    TCase *c = tcase_create("score_bits");
    tcase_add_test(c, scores_are_the_tables_bits);
    suite_add_tcase(s, c);
    return run_suite(s);
}
