/*
 * test_alloc_pipeline.c - allocation failures along the whole pipeline.
 *
 * Through the allocator hook (testutil's counting allocator), each step
 * below is run once to count its allocations n, then n times more with
 * allocation i failing, for every i < n: once with only the i-th failing
 * and once with the i-th and every later one failing. Each run must
 * either succeed with exactly the reference run's result, or return
 * PHKS_ERROR_OUT_OF_MEMORY with an "out of memory" message and NULL
 * outputs; the blocks the hook holds must be back to where they were
 * (LeakSanitizer in the ASan build catches what the hook cannot see);
 * and after the sweep an unfailed run must again give the reference
 * result, bit for bit.
 *
 * Steps: loading each format from a file and from memory (OFF, PLY, OBJ,
 * ascii and binary STL, gzip-compressed OFF in two members); spectra by
 * the exact path (dense LAPACK, block Lanczos, ARPACK) and by HKS-simp;
 * signatures from a mesh and from a spectrum (exact and HKS-simp, which
 * extends the HKS to every vertex); signature decode and encode; and a
 * database sequence (open, add, add_batch, query, get, remove, query,
 * add, and on a file close, open and the first query, which reads every
 * entry) on ":memory:" and on a file, where after every failing call the
 * database must answer count, list and a query exactly as before it.
 *
 * SQLite allocates through its own allocator, not through
 * phks_set_allocator(): the database steps cover the library's own
 * allocations (handle, cache, blobs, query buffers), not SQLite's.
 *
 * The counting allocator is not thread-safe and the i-th allocation must
 * be the same one on every run: everything runs on one thread (options
 * threads = 1; database queries of fewer than 4096 entries scan on the
 * calling thread). The meshes are small (162 vertices, 24 eigenpairs;
 * 408 and 8 for the iterative solvers, which need room) so that the
 * sweep takes seconds, and well under a minute under AddressSanitizer.
 */
#include "testutil.h"
#include "soup.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <zlib.h>

/* ---- results: what a step made, as plain bytes (outside the hook) */

static void put_text(bytes *b, const char *fmt, ...) PHKS__PRINTF(2, 3);
static void put_text(bytes *b, const char *fmt, ...)
{
    char line[256];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    REQUIRE(n > 0 && (size_t)n < sizeof line);
    put(b, line, (size_t)n);
}

static void put_mesh(bytes *b, const phks_mesh *m)
{
    size_t nv = phks_mesh_vertex_count(m), nt = phks_mesh_triangle_count(m);
    put(b, &nv, sizeof nv);
    put(b, &nt, sizeof nt);
    put(b, phks_mesh_vertices(m), 3 * nv * sizeof(double));
    put(b, phks_mesh_triangles(m), 3 * nt * sizeof(uint32_t));
    put(b, phks_mesh_vertex_origin(m), nv * sizeof(uint32_t));
}

/* The encoded blob: every number of the signature, bit for bit. */
static void put_signature(bytes *b, const phks_signature *sig)
{
    size_t size = phks_signature_encoded_size(sig), got = 0;
    unsigned char *blob = malloc(size);
    REQUIRE(blob);
    REQUIRE(phks_signature_encode(sig, blob, size, &got) == PHKS_OK);
    REQUIRE(got == size);
    put(b, blob, size);
    free(blob);
}

/* ---- the sweep */

/* A step makes its result into *out and frees everything it made with
 * the library; on failure it returns the status (out is then ignored). */
typedef phks_status (*step_fn)(void *ctx, bytes *out);

/* Runs fn with no failure and returns its result; *calls gets the number
 * of allocations it asked for. */
static bytes reference_run(const char *what, step_fn fn, void *ctx, long *calls)
{
    long live = alloc_live;
    bytes ref = {0};
    alloc_fail_at = -1;
    alloc_calls = 0;
    phks_status st = fn(ctx, &ref);
    REQUIRE_MSG(st == PHKS_OK, "%s: %s", what, phks_last_error_message());
    REQUIRE_MSG(alloc_live == live, "%s: %ld blocks leaked", what,
                alloc_live - live);
    *calls = alloc_calls;
    return ref;
}

/* Fails allocation i (and, with rest, all later ones) for every i below
 * the reference run's count; returns that count. */
static long sweep(const char *what, step_fn fn, void *ctx, long min_calls)
{
    double t0 = now();
    clock_t c0 = clock();
    long total;
    bytes ref = reference_run(what, fn, ctx, &total);
    REQUIRE_MSG(total >= min_calls, "%s: only %ld allocations", what, total);
    long live = alloc_live, failed[2] = {0, 0};
    for (int rest = 0; rest < 2; rest++)
        for (long i = 0; i < total; i++) {
            phks_mesh *dummy;
            (void)phks_mesh_load(NULL, &dummy); /* a message not about memory */
            bytes got = {0};
            alloc_calls = 0;
            alloc_fail_at = i;
            alloc_fail_rest = rest;
            phks_status st = fn(ctx, &got);
            alloc_fail_at = -1;
            alloc_fail_rest = false;
            if (st == PHKS_OK) {
                REQUIRE_MSG(got.n == ref.n && memcmp(got.p, ref.p, ref.n) == 0,
                            "%s: allocation %ld%s failed, the call succeeded "
                            "with another result",
                            what, i, rest ? " on" : "");
            } else {
                failed[rest]++;
                REQUIRE_MSG(st == PHKS_ERROR_OUT_OF_MEMORY,
                            "%s: allocation %ld%s failed: %s (%s)", what, i,
                            rest ? " on" : "", phks_status_string(st),
                            phks_last_error_message());
                REQUIRE_MSG(strstr(phks_last_error_message(), "memory"),
                            "%s: allocation %ld: message \"%s\"", what, i,
                            phks_last_error_message());
            }
            REQUIRE_MSG(alloc_live == live, "%s: allocation %ld%s failed: %ld "
                        "blocks leaked", what, i, rest ? " on" : "",
                        alloc_live - live);
            free(got.p);
        }
    /* Nothing that failed changed what the next run computes. */
    long again;
    bytes after = reference_run(what, fn, ctx, &again);
    REQUIRE_MSG(again == total, "%s: %ld allocations, then %ld", what, total,
                again);
    REQUIRE_MSG(after.n == ref.n && memcmp(after.p, ref.p, ref.n) == 0,
                "%s: the run after the sweep differs from the first", what);
    printf("%s: %ld allocations; failing one: %ld runs failed, failing all "
           "from one on: %ld (%.1f s, %.1f s CPU)\n",
           what, total, failed[0], failed[1], now() - t0,
           (double)(clock() - c0) / CLOCKS_PER_SEC);
    /* Failures that go unseen are those a call can do without (a
     * shrinking realloc); with every allocation from one on failing, no
     * run can succeed. */
    REQUIRE_MSG(failed[0] >= total - total / 4,
                "%s: %ld of %ld failures unseen", what, total - failed[0],
                total);
    REQUIRE_MSG(failed[1] == total, "%s: %ld runs succeeded with every "
                "allocation from one on failing", what, total - failed[1]);
    free(ref.p);
    free(after.p);
    return total;
}

/* ---- the mesh, and files of it */

static soup small_soup(void)
{
    uint64_t rng = 61;
    const double center[3] = {0.1, -0.2, 0.3}, axes[3] = {1, 0.8, 0.6};
    soup s = {0};
    add_icosphere(&s, 2, center, axes, 0.05, &rng); /* 162 vertices */
    return s;
}

static phks_options small_options(void)
{
    phks_options o;
    phks_options_init(&o);
    /* The vertices' quadrature: the default's points inside these
     * triangles would be some hundreds more to solve in every step of
     * every sweep; its own sweep is on a box (spectra_and_signatures). */
    o.quadrature = PHKS_QUADRATURE_VERTICES;
    o.eigen_count = 24;
    o.tau = 0.002;
    o.threads = 1;
    o.feature_count = 6;
    return o;
}

static void put_off(bytes *b, const soup *s)
{
    put_text(b, "OFF\n%zu %zu 0\n", s->nv, s->nt);
    for (size_t v = 0; v < s->nv; v++)
        put_text(b, "%.17g %.17g %.17g\n", s->xyz[3 * v], s->xyz[3 * v + 1],
                 s->xyz[3 * v + 2]);
    for (size_t t = 0; t < s->nt; t++)
        put_text(b, "3 %u %u %u\n", s->tri[3 * t], s->tri[3 * t + 1],
                 s->tri[3 * t + 2]);
}

static void put_obj(bytes *b, const soup *s)
{
    put_text(b, "# a test mesh\no sphere\n");
    for (size_t v = 0; v < s->nv; v++)
        put_text(b, "v %.17g %.17g %.17g\n", s->xyz[3 * v], s->xyz[3 * v + 1],
                 s->xyz[3 * v + 2]);
    for (size_t t = 0; t < s->nt; t++)
        put_text(b, "f %u %u/%u -%zu\n", s->tri[3 * t] + 1,
                 s->tri[3 * t + 1] + 1, s->tri[3 * t + 1] + 1,
                 s->nv - s->tri[3 * t + 2]);
}

/* Binary little-endian PLY: double coordinates, an extra float property,
 * uchar-counted int lists. */
static void put_ply(bytes *b, const soup *s)
{
    put_text(b, "ply\nformat binary_little_endian 1.0\nelement vertex %zu\n"
                "property double x\nproperty double y\nproperty double z\n"
                "property float quality\nelement face %zu\n"
                "property list uchar int vertex_indices\nend_header\n",
             s->nv, s->nt);
    for (size_t v = 0; v < s->nv; v++) {
        put(b, s->xyz + 3 * v, 3 * sizeof(double)); /* little-endian host */
        float q = (float)v;
        put(b, &q, sizeof q);
    }
    for (size_t t = 0; t < s->nt; t++) {
        unsigned char three = 3;
        put(b, &three, 1);
        for (int k = 0; k < 3; k++) {
            int32_t i = (int32_t)s->tri[3 * t + k];
            put(b, &i, sizeof i);
        }
    }
}

static void put_stl_ascii(bytes *b, const soup *s)
{
    put_text(b, "solid sphere\n");
    for (size_t t = 0; t < s->nt; t++) {
        put_text(b, " facet normal 0 0 0\n  outer loop\n");
        for (int k = 0; k < 3; k++) {
            const double *p = s->xyz + 3 * s->tri[3 * t + k];
            put_text(b, "   vertex %.9g %.9g %.9g\n", p[0], p[1], p[2]);
        }
        put_text(b, "  endloop\n endfacet\n");
    }
    put_text(b, "endsolid sphere\n");
}

static void put_stl_binary(bytes *b, const soup *s)
{
    char header[80] = "binary sphere";
    put(b, header, sizeof header);
    uint32_t n = (uint32_t)s->nt;
    put(b, &n, 4);
    for (size_t t = 0; t < s->nt; t++) {
        float f[12] = {0};
        for (int k = 0; k < 3; k++)
            for (int d = 0; d < 3; d++)
                f[3 + 3 * k + d] = (float)s->xyz[3 * s->tri[3 * t + k] + d];
        put(b, f, sizeof f);
        put(b, "\0\0", 2);
    }
}

/* OFF with 96 KiB of comment lines after the keyword. */
static void put_off_padded(bytes *b, const soup *s)
{
    put_text(b, "OFF\n");
    for (int i = 0; i < 4096; i++)
        put_text(b, "# comment line %5d, to make the file longer\n", i);
    bytes rest = {0};
    put_off(&rest, s);
    put(b, rest.p + 4, rest.n - 4);
    free(rest.p);
}

/* Appends one gzip member holding n bytes of data. */
static void put_gzip_member(bytes *out, const unsigned char *data, size_t n)
{
    z_stream z;
    memset(&z, 0, sizeof z);
    REQUIRE(deflateInit2(&z, 9, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) ==
            Z_OK);
    size_t room = deflateBound(&z, (uLong)n) + 64;
    unsigned char *p = malloc(room);
    REQUIRE(p);
    z.next_in = (unsigned char *)(uintptr_t)data;
    z.avail_in = (uInt)n;
    z.next_out = p;
    z.avail_out = (uInt)room;
    REQUIRE(deflate(&z, Z_FINISH) == Z_STREAM_END);
    put(out, p, room - z.avail_out);
    free(p);
    deflateEnd(&z);
}

/* Two members, the second holding only the last 100 bytes: the loader's
 * first guess at the size (the trailer's, which is the last member's) is
 * too small, so its buffer grows while it inflates, and inflating more
 * than one window's worth makes zlib allocate its window. */
static bytes gzip_of(const bytes *in)
{
    bytes out = {0};
    REQUIRE(in->n > 100);
    put_gzip_member(&out, in->p, in->n - 100);
    put_gzip_member(&out, in->p + in->n - 100, 100);
    return out;
}

static void write_file(const char *path, const bytes *b)
{
    FILE *f = fopen(path, "wb");
    REQUIRE(f);
    REQUIRE(fwrite(b->p, 1, b->n, f) == b->n);
    REQUIRE(fclose(f) == 0);
}

/* ---- steps: loading */

typedef struct load_ctx {
    const char *path;  /* phks_mesh_load, or else */
    const bytes *data; /* phks_mesh_load_memory, format AUTO */
} load_ctx;

static phks_status step_load(void *ctx, bytes *out)
{
    const load_ctx *c = ctx;
    phks_mesh *m = (phks_mesh *)out; /* must be overwritten */
    phks_status st = c->path ? phks_mesh_load(c->path, &m)
                             : phks_mesh_load_memory(c->data->p, c->data->n,
                                                     PHKS_FORMAT_AUTO, &m);
    if (st != PHKS_OK) {
        REQUIRE(m == NULL);
        return st;
    }
    put_mesh(out, m);
    phks_mesh_free(m);
    return PHKS_OK;
}

START_TEST(loading)
{
    static const struct {
        const char *name;
        void (*write)(bytes *, const soup *);
        bool gzip;
    } formats[] = {{"mesh.off", put_off, false},
                   {"mesh.obj", put_obj, false},
                   {"mesh.ply", put_ply, false},
                   {"mesh.stl", put_stl_ascii, false},
                   {"binary.stl", put_stl_binary, false},
                   {"mesh.off.gz", put_off_padded, true}};
    phks_allocator counting = {count_malloc, count_realloc, count_free, NULL};
    ck_assert_int_eq(phks_set_allocator(&counting), PHKS_OK);
    alloc_live = 0;
    soup s = small_soup();
    char dir[] = "/tmp/phks-alloc-XXXXXX";
    ck_assert_ptr_nonnull(mkdtemp(dir));
    for (size_t f = 0; f < sizeof formats / sizeof *formats; f++) {
        bytes data = {0};
        formats[f].write(&data, &s);
        if (formats[f].gzip) {
            bytes gz = gzip_of(&data);
            free(data.p);
            data = gz;
        }
        char path[64], what[96];
        snprintf(path, sizeof path, "%s/%s", dir, formats[f].name);
        write_file(path, &data);
        load_ctx from_file = {path, NULL}, from_memory = {NULL, &data};
        snprintf(what, sizeof what, "load %s", formats[f].name);
        long from_disk = sweep(what, step_load, &from_file, 5);
        snprintf(what, sizeof what, "load_memory %s", formats[f].name);
        long in_memory = sweep(what, step_load, &from_memory, 5);
        /* a file adds the buffer it is read into */
        ck_assert_int_eq(from_disk, in_memory + 1);
        /* Both ways give the same mesh, which is the soup's. */
        long calls;
        bytes a = reference_run("file", step_load, &from_file, &calls);
        bytes b = reference_run("memory", step_load, &from_memory, &calls);
        ck_assert_uint_eq(a.n, b.n);
        ck_assert_mem_eq(a.p, b.p, a.n);
        size_t counts[2];
        memcpy(counts, a.p, sizeof counts);
        ck_assert_uint_eq(counts[0], s.nv);
        ck_assert_uint_eq(counts[1], s.nt);
        free(a.p);
        free(b.p);
        free(data.p);
        ck_assert_int_eq(unlink(path), 0);
    }
    ck_assert_int_eq(rmdir(dir), 0);
    soup_free(&s);
    ck_assert_int_eq(alloc_live, 0);
    ck_assert_int_eq(phks_set_allocator(NULL), PHKS_OK);
}
END_TEST

/* ---- steps: spectra and signatures */

typedef struct compute_ctx {
    const phks_mesh *mesh;
    phks_options options;
    const phks_spectrum *spectrum; /* for step_hks, step_from_spectrum */
    const bytes *blob;             /* for step_decode */
} compute_ctx;

static phks_status step_spectrum(void *ctx, bytes *out)
{
    const compute_ctx *c = ctx;
    phks_spectrum *s = (phks_spectrum *)out;
    phks_status st = phks_spectrum_compute(c->mesh, &c->options, &s);
    if (st != PHKS_OK) {
        REQUIRE(s == NULL);
        return st;
    }
    size_t k = phks_spectrum_count(s), m = phks_spectrum_sample_count(s);
    put(out, phks_spectrum_eigenvalues(s), k * sizeof(double));
    for (size_t i = 0; i < k; i++)
        put(out, phks_spectrum_eigenvector(s, i), m * sizeof(double));
    put(out, phks_spectrum_mass(s), m * sizeof(double));
    phks_spectrum_free(s);
    return PHKS_OK;
}

/* HKS of a spectrum computed beforehand (with HKS-simp, the extension to
 * every vertex allocates its own buffers on each call). */
static phks_status step_hks(void *ctx, bytes *out)
{
    const compute_ctx *c = ctx;
    size_t n = phks_spectrum_vertex_count(c->spectrum);
    double *hks = malloc(n * sizeof *hks);
    REQUIRE(hks);
    phks_status st = phks_spectrum_hks(c->spectrum, 5 * c->options.tau, hks);
    if (st == PHKS_OK)
        put(out, hks, n * sizeof *hks);
    free(hks);
    return st;
}

/* What a call that made sig returned: on failure sig must be NULL; on
 * success its encoding goes to out and it is freed. */
static phks_status take_signature(phks_status st, phks_signature *sig,
                                  bytes *out)
{
    if (st != PHKS_OK) {
        REQUIRE(sig == NULL);
        return st;
    }
    put_signature(out, sig);
    phks_signature_free(sig);
    return PHKS_OK;
}

static phks_status step_signature(void *ctx, bytes *out)
{
    const compute_ctx *c = ctx;
    phks_signature *sig = (phks_signature *)out;
    phks_status st = phks_signature_compute(c->mesh, &c->options, &sig);
    return take_signature(st, sig, out);
}

static phks_status step_from_spectrum(void *ctx, bytes *out)
{
    const compute_ctx *c = ctx;
    phks_signature *sig = (phks_signature *)out;
    phks_status st =
        phks_signature_from_spectrum(c->mesh, c->spectrum, &c->options, &sig);
    return take_signature(st, sig, out);
}

/* The same from three of the caller's vertices. */
static phks_status step_at_vertices(void *ctx, bytes *out)
{
    const compute_ctx *c = ctx;
    const uint32_t vertices[3] = {0, 50, 100};
    phks_signature *sig = (phks_signature *)out;
    phks_status st = phks_signature_at_vertices(c->mesh, c->spectrum,
                                                &c->options, vertices, 3, &sig);
    return take_signature(st, sig, out);
}

/* decode, then encode again (encode itself writes into the caller's
 * buffer and allocates nothing; the sweep checks that too). */
static phks_status step_decode(void *ctx, bytes *out)
{
    const compute_ctx *c = ctx;
    phks_signature *sig = (phks_signature *)out;
    phks_status st = phks_signature_decode(c->blob->p, c->blob->n, &sig);
    if (st != PHKS_OK) {
        REQUIRE(sig == NULL);
        return st;
    }
    long before = alloc_calls;
    put_signature(out, sig);
    REQUIRE(alloc_calls == before);
    phks_signature_free(sig);
    return PHKS_OK;
}

START_TEST(spectra_and_signatures)
{
    phks_allocator counting = {count_malloc, count_realloc, count_free, NULL};
    ck_assert_int_eq(phks_set_allocator(&counting), PHKS_OK);
    alloc_live = 0;
    soup s = small_soup();
    phks_mesh *mesh = soup_mesh(&s);
    soup_free(&s);
    compute_ctx c = {mesh, small_options(), NULL, NULL};

    /* The exact spectrum, by the default solver (dense below 1000
     * vertices), then by block Lanczos and ARPACK on 408 vertices, 8
     * eigenpairs (on 162 Lanczos would hand over to the dense solver). */
    sweep("spectrum dense", step_spectrum, &c, 10);
    sweep("signature", step_signature, &c, 10);
    uint64_t rng = 62;
    add_torus(&s, 24, 17, 1, 0.4, 0.3, &rng); /* 408 vertices */
    phks_mesh *larger = soup_mesh(&s);
    soup_free(&s);
    compute_ctx cl = {larger, small_options(), NULL, NULL};
    cl.options.eigen_count = 8;
    cl.options.tolerance = 1e-6;
    cl.options.solver = PHKS_SOLVER_LANCZOS;
    long lanczos = sweep("spectrum lanczos", step_spectrum, &cl, 10);
    cl.options.solver = PHKS_SOLVER_ARPACK;
    sweep("spectrum arpack", step_spectrum, &cl, 10);
    /* Lanczos did run: the dense solver asks for fewer blocks */
    long dense;
    cl.options.solver = PHKS_SOLVER_DENSE;
    bytes d = reference_run("dense", step_spectrum, &cl, &dense);
    free(d.p);
    ck_assert_int_gt(lanczos, dense);
    phks_mesh_free(larger);

    /* HKS-simp: 162 vertices reduced to about 32 samples. */
    phks_options simp = small_options();
    simp.simplify_above = 100;
    simp.simplify_target = 32;
    simp.eigen_count = 12;
    compute_ctx cs = {mesh, simp, NULL, NULL};
    phks_spectrum *spec = NULL;
    ck_assert_int_eq(phks_spectrum_compute(mesh, &simp, &spec), PHKS_OK);
    ck_assert_uint_lt(phks_spectrum_sample_count(spec), 100); /* simplified */
    phks_spectrum_free(spec);
    sweep("spectrum HKS-simp", step_spectrum, &cs, 10);

    /* The default triangle quadrature (lib/geometry/quadrature.c): a cube
     * of 12 triangles, each longer than the kernel's width, at a tau that
     * keeps its points to about a hundred and fifty. */
    soup box = {0};
    const double side[3] = {1, 1, 1};
    const size_t one[3] = {1, 1, 1};
    add_box(&box, side, one);
    phks_mesh *cube = soup_mesh_take(&box);
    compute_ctx cq = {cube, small_options(), NULL, NULL};
    cq.options.quadrature = PHKS_QUADRATURE_TRIANGLES;
    cq.options.tau = 0.02;
    cq.options.eigen_count = 8;
    sweep("signature triangles", step_signature, &cq, 10);
    phks_mesh_free(cube);

    /* HKS and signatures from a spectrum computed beforehand, exact and
     * simplified; phks_signature_compute is the two steps in one, which
     * the sweep of the exact path above covers as a whole. */
    for (int simplified = 0; simplified < 2; simplified++) {
        compute_ctx *cc = simplified ? &cs : &c;
        ck_assert_int_eq(phks_spectrum_compute(mesh, &cc->options, &spec),
                         PHKS_OK);
        cc->spectrum = spec;
        if (simplified) { /* the exact HKS allocates nothing */
            long calls;
            bytes h = reference_run("hks HKS-simp", step_hks, cc, &calls);
            ck_assert_int_gt(calls, 0);
            free(h.p);
        }
        sweep(simplified ? "from_spectrum HKS-simp" : "from_spectrum",
              step_from_spectrum, cc, 3);
        sweep(simplified ? "at_vertices HKS-simp" : "at_vertices",
              step_at_vertices, cc, 3);
        /* the same signature as the whole pipeline gives */
        long calls;
        bytes a = reference_run("whole", step_signature, cc, &calls);
        bytes b = reference_run("parts", step_from_spectrum, cc, &calls);
        ck_assert_uint_eq(a.n, b.n);
        ck_assert_mem_eq(a.p, b.p, a.n);
        free(a.p);
        free(b.p);
        phks_spectrum_free(spec);
        cc->spectrum = NULL;
    }

    /* Decode of a blob of that signature. */
    long calls;
    bytes blob = reference_run("blob", step_signature, &c, &calls);
    c.blob = &blob;
    sweep("decode", step_decode, &c, 1);
    bytes again = reference_run("decode", step_decode, &c, &calls);
    ck_assert_uint_eq(again.n, blob.n);
    ck_assert_mem_eq(again.p, blob.p, blob.n);
    free(again.p);
    free(blob.p);

    phks_mesh_free(mesh);
    ck_assert_int_eq(alloc_live, 0);
    ck_assert_int_eq(phks_set_allocator(NULL), PHKS_OK);
}
END_TEST

/* ---- steps: the database */

typedef struct db_ctx {
    const char *path; /* ":memory:" or a file, made afresh by each run */
    phks_signature *sigs[4];
    phks_signature *query;
} db_ctx;

/* Between suspend() and resume() no allocation fails and none is
 * counted. */
static long suspended_fail_at, suspended_calls;

static void suspend(void)
{
    suspended_fail_at = alloc_fail_at;
    suspended_calls = alloc_calls;
    alloc_fail_at = -1;
}

static void resume(void)
{
    alloc_fail_at = suspended_fail_at;
    alloc_calls = suspended_calls;
}

/* What the database answers, read with no allocation failing and without
 * counting the allocations it takes: count, every id, and the hits of a
 * query over all entries. */
static void snapshot(phks_db *db, const phks_signature *query, bytes *out)
{
    suspend();
    size_t count = 99, listed = 99;
    REQUIRE(phks_db_count(db, &count) == PHKS_OK);
    int64_t ids[16];
    REQUIRE(phks_db_list(db, 0, ids, 16, &listed) == PHKS_OK);
    REQUIRE(listed == count);
    put(out, &count, sizeof count);
    put(out, ids, listed * sizeof *ids);
    phks_hit hits[16];
    size_t found = 99;
    REQUIRE(phks_db_query(db, query, 16, hits, &found) == PHKS_OK);
    REQUIRE(found == count);
    for (size_t i = 0; i < found; i++) {
        put(out, &hits[i].id, sizeof hits[i].id);
        put(out, &hits[i].score, sizeof hits[i].score);
        put(out, hits[i].name, strlen(hits[i].name) + 1);
        put(out, hits[i].label, strlen(hits[i].label) + 1);
    }
    resume();
}

static bool same_bytes(const bytes *a, const bytes *b)
{
    return a->n == b->n && memcmp(a->p, b->p, a->n) == 0;
}

static void remove_db_files(const char *path)
{
    static const char *suffixes[] = {"", "-wal", "-shm", "-journal"};
    for (size_t i = 0; i < 4; i++) {
        char name[128];
        snprintf(name, sizeof name, "%s%s", path, suffixes[i]);
        unlink(name);
    }
}

/* Every call may fail cleanly; then the database must answer as before
 * it, and the sequence goes on. The result is each call's status and
 * answer and the final state, so a run with no failure must give the
 * reference bit for bit. Returns OUT_OF_MEMORY if any call failed. */
static phks_status step_db(void *ctx, bytes *out)
{
    const db_ctx *c = ctx;
    if (strcmp(c->path, ":memory:") != 0)
        remove_db_files(c->path);
    /* 0 add, 1 add_batch, 2 query, 3 get, 4 remove, 5 query, 6 add, 7 on
     * a file: close and open again, then the first query of the new
     * handle, which reads every entry into its cache; in memory: a query. */
    phks_db *db = (phks_db *)out;
    phks_status st = phks_db_open(c->path, PHKS_DB_CREATE, &db);
    if (st != PHKS_OK) {
        REQUIRE(db == NULL);
        return st;
    }
    phks_status worst = PHKS_OK;
    int64_t id_a = 0, ids_bc[2] = {0, 0};
    phks_db_entry batch[2] = {{"b", "two", c->sigs[1]},
                              {"c\xc3\xa9", NULL, c->sigs[2]}};
    bool on_disk = strcmp(c->path, ":memory:") != 0;
    for (int call = 0; call < 8; call++) {
        bytes before = {0}, after = {0}, answer = {0};
        snapshot(db, c->query, &before);
        phks_hit hits[8];
        size_t found = 0;
        phks_signature *back = NULL;
        char name[16] = "", label[16] = "";
        size_t ignored;
        (void)phks_db_count(NULL, &ignored); /* a message not about memory */
        switch (call) {
        case 0: st = phks_db_add(db, "a", "one", c->sigs[0], &id_a); break;
        case 1: st = phks_db_add_batch(db, batch, 2, ids_bc); break;
        case 2:
        case 5: st = phks_db_query(db, c->sigs[call == 2 ? 1 : 3], 8, hits,
                                   &found);
            break;
        case 3: /* the entry a, if its add went through */
            st = id_a ? phks_db_get(db, id_a, &back, name, sizeof name, label,
                                    sizeof label)
                      : PHKS_OK;
            break;
        case 4: st = ids_bc[0] ? phks_db_remove(db, ids_bc[0]) : PHKS_OK; break;
        case 6: st = phks_db_add(db, "d", "", c->sigs[3], NULL); break;
        case 7:
            st = PHKS_OK;
            if (on_disk) {
                phks_db_close(db);
                st = phks_db_open(c->path, 0, &db);
                if (st != PHKS_OK) {
                    REQUIRE(db == NULL);
                    suspend();
                    REQUIRE(phks_db_open(c->path, 0, &db) == PHKS_OK);
                    resume();
                }
            }
            /* the first query of a handle: every entry read into it */
            phks_status q = phks_db_query(db, c->sigs[0], 8, hits, &found);
            st = st != PHKS_OK ? st : q;
            break;
        }
        snapshot(db, c->query, &after);
        put(out, &st, sizeof st);
        if (st != PHKS_OK) {
            worst = st;
            REQUIRE_MSG(st == PHKS_ERROR_OUT_OF_MEMORY, "db call %d: %s", call,
                        phks_last_error_message());
            REQUIRE_MSG(strstr(phks_last_error_message(), "memory"),
                        "db call %d: message \"%s\"", call,
                        phks_last_error_message());
            REQUIRE(back == NULL);
            REQUIRE_MSG(same_bytes(&before, &after),
                        "db call %d failed and changed the database", call);
        } else if (call == 2 || call == 3 || call == 5 || call >= 7) {
            REQUIRE_MSG(same_bytes(&before, &after),
                        "db call %d read and changed the database", call);
        }
        if (call == 2 || call == 5 || call == 7) /* the hits */
            for (size_t i = 0; i < found; i++) {
                put(&answer, &hits[i].id, sizeof hits[i].id);
                put(&answer, &hits[i].score, sizeof hits[i].score);
                put(&answer, hits[i].name, strlen(hits[i].name) + 1);
            }
        if (back) {
            put(&answer, name, strlen(name) + 1);
            put(&answer, label, strlen(label) + 1);
            put_signature(&answer, back);
            phks_signature_free(back);
        }
        put(out, answer.p, answer.n);
        put(out, after.p, after.n);
        free(before.p);
        free(after.p);
        free(answer.p);
    }
    phks_db_close(db);
    return worst;
}

/* Signatures of four small meshes, computed (not synthetic) so the
 * database holds what users put in it. */
static phks_signature *computed(unsigned subdiv, uint64_t seed, double squash)
{
    uint64_t rng = seed;
    const double center[3] = {0, 0, 0}, axes[3] = {1, 0.9, squash};
    soup s = {0};
    add_icosphere(&s, subdiv, center, axes, 0.05, &rng);
    phks_mesh *m = soup_mesh_take(&s);
    phks_options o = small_options();
    phks_signature *sig = NULL;
    REQUIRE(phks_signature_compute(m, &o, &sig) == PHKS_OK);
    phks_mesh_free(m);
    return sig;
}

START_TEST(database)
{
    phks_allocator counting = {count_malloc, count_realloc, count_free, NULL};
    ck_assert_int_eq(phks_set_allocator(&counting), PHKS_OK);
    alloc_live = 0;
    char dir[] = "/tmp/phks-alloc-db-XXXXXX";
    ck_assert_ptr_nonnull(mkdtemp(dir));
    char file[64];
    snprintf(file, sizeof file, "%s/shapes.db", dir);
    db_ctx c = {":memory:",
                {computed(2, 1, 0.5), computed(2, 2, 0.7), computed(2, 3, 0.9),
                 computed(1, 4, 0.6)},
                computed(2, 5, 0.55)};
    for (int on_disk = 0; on_disk < 2; on_disk++) {
        c.path = on_disk ? file : ":memory:";
        const char *what = on_disk ? "database file" : "database :memory:";
        double t0 = now();
        long total;
        bytes ref = reference_run(what, step_db, &c, &total);
        ck_assert_int_ge(total, on_disk ? 40 : 30);
        long live = alloc_live, failed[2] = {0, 0};
        for (int rest = 0; rest < 2; rest++)
            for (long i = 0; i < total; i++) {
                bytes got = {0};
                alloc_calls = 0;
                alloc_fail_at = i;
                alloc_fail_rest = rest;
                phks_status st = step_db(&c, &got);
                alloc_fail_at = -1;
                alloc_fail_rest = false;
                if (st != PHKS_OK)
                    failed[rest]++;
                else /* a failure nobody saw changed nothing */
                    REQUIRE_MSG(same_bytes(&got, &ref),
                                "%s: allocation %ld failed unseen, and the "
                                "answers changed",
                                what, i);
                REQUIRE_MSG(alloc_live == live,
                            "%s: allocation %ld%s failed: %ld blocks leaked",
                            what, i, rest ? " on" : "", alloc_live - live);
                free(got.p);
            }
        /* Only refills of the query cache may fail unseen (the next query
         * reloads it); with every allocation from one on failing, the
         * sequence's last add fails in every run. */
        ck_assert_int_ge(failed[0], total / 2);
        ck_assert_int_eq(failed[1], total);
        long again;
        bytes after = reference_run(what, step_db, &c, &again);
        ck_assert_int_eq(again, total);
        ck_assert(same_bytes(&after, &ref));
        printf("%s: %ld allocations; failing one: %ld runs failed, failing "
               "all from one on: %ld (%.1f s)\n",
               what, total, failed[0], failed[1], now() - t0);
        free(ref.p);
        free(after.p);
    }
    remove_db_files(file);
    ck_assert_int_eq(rmdir(dir), 0);
    for (int i = 0; i < 4; i++)
        phks_signature_free(c.sigs[i]);
    phks_signature_free(c.query);
    ck_assert_int_eq(alloc_live, 0);
    ck_assert_int_eq(phks_set_allocator(NULL), PHKS_OK);
}
END_TEST

static void add_case(Suite *s, const char *name, const TTest *test)
{
    TCase *c = tcase_create(name);
    tcase_set_timeout(c, 300);
    tcase_add_test(c, test);
    suite_add_tcase(s, c);
}

/* One case per part, so CK_RUN_CASE=database runs one. */
int main(void)
{
    Suite *s = suite_create("alloc_pipeline");
    add_case(s, "loading", loading);
    add_case(s, "compute", spectra_and_signatures);
    add_case(s, "database", database);
    return run_suite(s);
}
