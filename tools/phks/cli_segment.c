/*
 * cli_segment.c - `phks segment MESH -o OUT.ply`: the persistent maxima of
 * the HKS at feature_scale * tau and the regions they induce, written as an
 * ASCII PLY with a colour per region (per-face red/green/blue, which MeshLab
 * shows) and the faces around each feature point white.
 */
#include "cli.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct segmentation {
    phks_maximum *maxima;
    size_t count;
    uint32_t *region;  /* per triangle; UINT32_MAX: no region */
} segmentation;

/* Kelly's colours of maximum contrast without white, black and grey; then
 * hues spaced by the golden angle. */
static void region_colour(uint32_t r, unsigned char rgb[3])
{
    static const unsigned char kelly[][3] = {
        {243, 195, 0},   {135, 86, 146},  {243, 132, 0},   {161, 202, 241},
        {190, 0, 50},    {194, 178, 128}, {0, 136, 86},    {230, 143, 172},
        {0, 103, 165},   {249, 147, 121}, {96, 78, 151},   {246, 166, 0},
        {179, 68, 108},  {220, 211, 0},   {136, 45, 23},   {141, 182, 0},
        {101, 69, 34},   {226, 88, 34},   {43, 61, 38},
    };
    enum { K = sizeof kelly / sizeof kelly[0] };
    if (r == UINT32_MAX) {
        rgb[0] = rgb[1] = rgb[2] = 128;
        return;
    }
    if (r < K) {
        memcpy(rgb, kelly[r], 3);
        return;
    }
    double h = fmod((r - K) * 0.618033988749895, 1.0) * 6, f = h - floor(h);
    double v[6][3] = {{1, f, 0}, {1 - f, 1, 0}, {0, 1, f},
                      {0, 1 - f, 1}, {f, 0, 1}, {1, 0, 1 - f}};
    for (int c = 0; c < 3; c++)
        rgb[c] = (unsigned char)(40 + 170 * v[(int)h % 6][c]);
}

static phks_status segment(const phks_mesh *mesh, const phks_options *o,
                           segmentation *seg)
{
    size_t n = phks_mesh_vertex_count(mesh), m = phks_mesh_triangle_count(mesh);
    size_t cap = o->feature_count < m ? o->feature_count : m;
    phks_spectrum *spec = NULL;
    double *hks = malloc(n * sizeof *hks);
    seg->maxima = malloc(cap * sizeof *seg->maxima);
    seg->region = malloc(m * sizeof *seg->region);
    phks_status st = hks && seg->maxima && seg->region
                         ? phks_spectrum_compute(mesh, o, &spec)
                         : PHKS_ERROR_OUT_OF_MEMORY;
    if (st == PHKS_OK)
        st = phks_spectrum_hks(spec, o->feature_scale * o->tau, hks);
    if (st == PHKS_OK)
        st = phks_persistent_maxima(mesh, hks, o->feature_count, 0.0,
                                    seg->maxima, &seg->count, seg->region);
    phks_spectrum_free(spec);
    free(hks);
    return st;
}

/* The shortest of %.15g..%.17g that reads back as x. */
static const char *shortest(char buf[32], double x)
{
    for (int digits = 15; digits < 17; digits++) {
        snprintf(buf, 32, "%.*g", digits, x);
        if (strtod(buf, NULL) == x)
            return buf;
    }
    snprintf(buf, 32, "%.17g", x);
    return buf;
}

static void write_ply(FILE *f, const phks_mesh *mesh, const segmentation *seg)
{
    size_t n = phks_mesh_vertex_count(mesh), m = phks_mesh_triangle_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    const uint32_t *tri = phks_mesh_triangles(mesh);
    unsigned char *feature = calloc(n ? n : 1, 1);
    for (size_t i = 0; feature && i < seg->count; i++)
        feature[seg->maxima[i].vertex] = 1;
    fprintf(f, "ply\nformat ascii 1.0\ncomment phks segment: %zu regions, "
            "faces around feature points white\nelement vertex %zu\n"
            "property double x\nproperty double y\nproperty double z\n"
            "element face %zu\nproperty list uchar int vertex_indices\n"
            "property uchar red\nproperty uchar green\nproperty uchar blue\n"
            "end_header\n", seg->count, n, m);
    for (size_t v = 0; v < n; v++) {
        char x[32], y[32], z[32];
        fprintf(f, "%s %s %s\n", shortest(x, xyz[3 * v]),
                shortest(y, xyz[3 * v + 1]), shortest(z, xyz[3 * v + 2]));
    }
    for (size_t t = 0; t < m; t++) {
        const uint32_t *c = tri + 3 * t;
        unsigned char rgb[3] = {255, 255, 255};
        if (!feature || !(feature[c[0]] || feature[c[1]] || feature[c[2]]))
            region_colour(seg->region[t], rgb);
        fprintf(f, "3 %u %u %u %u %u %u\n", c[0], c[1], c[2], rgb[0], rgb[1],
                rgb[2]);
    }
    free(feature);
}

static int save(const char *path, const phks_mesh *mesh,
                const segmentation *seg)
{
    char *text = NULL;
    size_t size = 0;
    FILE *f = open_memstream(&text, &size);
    if (!f)
        return cli_error(path, strerror(errno));
    write_ply(f, mesh, seg);
    int bad = ferror(f);
    bad |= fclose(f) != 0;
    if (bad || cli_write_file_atomic(path, text, size) != 0) {
        free(text);
        return cli_error(path, strerror(errno ? errno : ENOMEM));
    }
    free(text);
    return 0;
}

static void print_regions(const phks_mesh *mesh, const segmentation *seg)
{
    size_t m = phks_mesh_triangle_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    size_t *faces = calloc(seg->count + 1, sizeof *faces);
    for (size_t t = 0; faces && t < m; t++)
        if (seg->region[t] < seg->count)
            faces[seg->region[t]]++;
    printf("%6s %9s %8s %12s %12s %12s %12s %12s\n", "region", "triangles",
           "vertex", "x", "y", "z", "HKS", "persistence");
    for (size_t r = 0; r < seg->count; r++) {
        const phks_maximum *x = &seg->maxima[r];
        const double *p = xyz + 3 * (size_t)x->vertex;
        printf("%6zu %9zu %8u %12.6g %12.6g %12.6g %12.6g %12.6g\n", r,
               faces ? faces[r] : 0, x->vertex, p[0], p[1], p[2], x->value,
               x->persistence);
    }
    free(faces);
}

int cli_segment(int argc, char **argv, const phks_options *options)
{
    const char *out = NULL;
    const cli_opt opts[] = {{"-o", &out, NULL}};
    int n;
    if (cli_parse(argc, argv, 1, opts, 1, &n) != 0 || n != 1 || !out)
        return cli_usage("segment MESH -o OUT.ply");
    phks_mesh *mesh;
    phks_status st = phks_mesh_load(argv[1], &mesh);
    if (st != PHKS_OK)
        return cli_fail(argv[1], st);
    segmentation seg = {0};
    st = segment(mesh, options, &seg);
    int rc = st != PHKS_OK ? cli_fail(argv[1], st) : save(out, mesh, &seg);
    if (rc == 0) {
        printf("%s: %zu vertices, %zu triangles; %zu regions of HKS at "
               "t = %g tau\n", argv[1], phks_mesh_vertex_count(mesh),
               phks_mesh_triangle_count(mesh), seg.count,
               options->feature_scale);
        print_regions(mesh, &seg);
        printf("wrote %s\n", out);
    }
    free(seg.maxima);
    free(seg.region);
    phks_mesh_free(mesh);
    return rc;
}
