/*
 * cli_segment.c - `phks segment MESH -o OUT.ply`: the persistent maxima of
 * the HKS at T tau and the regions they induce, written as a PLY (binary
 * little-endian, or ASCII with --ascii): per vertex its position and the
 * colour of its region (the region of most of its triangles), per face the
 * region and its colour, and the feature points as an element of their
 * own. Vertex ids printed are the input file's.
 */
#include "cli.h"
#include "common/cli_common.h"
#include "render/cli_pictures.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char usage[] =
    "segment MESH -o OUT.ply [--regions N] [--time T] [--ascii] [--json]\n"
    "  -o OUT.ply     the PLY to write (required; only PLY is written)\n"
    "  --regions N    at most N regions, 1..100000 (15)\n"
    "  --time T       HKS time in units of tau, above 0, at most 1e9 (5)\n"
    "  --ascii        ASCII PLY (binary little-endian)\n"
    "  --json         print the regions as JSON (text)\n"
    "  global options: see `phks --help`";

typedef struct segmentation {
    phks_maximum *maxima;
    size_t count;
    uint32_t *region;  /* per triangle; UINT32_MAX: no region */
    uint32_t *vertex_region; /* per vertex: most of its triangles' */
} segmentation;

static phks_status segment(const phks_mesh *mesh, const phks_options *o,
                           size_t regions, double time, const char *what,
                           segmentation *seg)
{
    size_t n = phks_mesh_vertex_count(mesh), m = phks_mesh_triangle_count(mesh);
    size_t cap = regions < m ? regions : m;
    phks_spectrum *spec = NULL;
    double *hks = malloc(n * sizeof *hks);
    phks_options opt = *o;
    cli_stages stages;
    cli_stages_attach(&stages, what, &opt);
    seg->maxima = malloc(cap * sizeof *seg->maxima);
    seg->region = malloc(m * sizeof *seg->region);
    phks_status st = hks && seg->maxima && seg->region
                         ? phks_spectrum_compute(mesh, &opt, &spec)
                         : PHKS_ERROR_OUT_OF_MEMORY;
    cli_stages_note(&stages, "heat kernel signature");
    if (st == PHKS_OK)
        st = phks_spectrum_hks(spec, time * o->tau, hks);
    cli_stages_note(&stages, "regions");
    if (st == PHKS_OK)
        st = phks_persistent_maxima(mesh, hks, regions, 0.0, seg->maxima,
                                    &seg->count, seg->region);
    cli_stages_end(&stages);
    phks_spectrum_free(spec);
    free(hks);
    return st;
}

/* Each vertex takes the region of most of its triangles
 * (cli_vertex_regions). */
static int vertex_regions(const phks_mesh *mesh, segmentation *seg)
{
    size_t n = phks_mesh_vertex_count(mesh);
    seg->vertex_region = malloc((n ? n : 1) * sizeof *seg->vertex_region);
    return seg->vertex_region
               ? cli_vertex_regions(mesh, seg->region, seg->vertex_region)
               : -1;
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

static void put_u32(FILE *f, uint32_t x)
{
    unsigned char b[4] = {(unsigned char)x, (unsigned char)(x >> 8),
                          (unsigned char)(x >> 16), (unsigned char)(x >> 24)};
    fwrite(b, 1, 4, f);
}

static void put_f64(FILE *f, double x)
{
    uint64_t u;
    memcpy(&u, &x, 8);
    put_u32(f, (uint32_t)u);
    put_u32(f, (uint32_t)(u >> 32));
}

static void put_xyz(FILE *f, const double *p, int ascii)
{
    char b[3][32];
    if (ascii)
        fprintf(f, "%s %s %s", shortest(b[0], p[0]), shortest(b[1], p[1]),
                shortest(b[2], p[2]));
    else
        for (int c = 0; c < 3; c++)
            put_f64(f, p[c]);
}

static int32_t region_int(uint32_t r)
{
    return r == UINT32_MAX ? -1 : (int32_t)r;
}

static void write_ply(FILE *f, const phks_mesh *mesh, const segmentation *seg,
                      int ascii)
{
    size_t n = phks_mesh_vertex_count(mesh), m = phks_mesh_triangle_count(mesh);
    const double *xyz = phks_mesh_vertices(mesh);
    const uint32_t *tri = phks_mesh_triangles(mesh);
    fprintf(f, "ply\nformat %s 1.0\ncomment phks segment: %zu regions\n"
            "comment vertices: the file's used vertices, in its order; "
            "file_vertex is each one's id in the file\n"
            "element vertex %zu\nproperty double x\nproperty double y\n"
            "property double z\nproperty uchar red\nproperty uchar green\n"
            "property uchar blue\nproperty int region\n"
            "property int file_vertex\n"
            "element face %zu\nproperty list uchar int vertex_indices\n"
            "property int region\nproperty uchar red\nproperty uchar green\n"
            "property uchar blue\nelement feature %zu\nproperty double x\n"
            "property double y\nproperty double z\nproperty int region\n"
            "property int vertex\nproperty int file_vertex\nend_header\n",
            ascii ? "ascii" : "binary_little_endian", seg->count, n, m,
            seg->count);
    for (size_t v = 0; v < n; v++) {
        unsigned char rgb[3];
        cli_region_colour(seg->vertex_region[v], rgb);
        put_xyz(f, xyz + 3 * v, ascii);
        int32_t r = region_int(seg->vertex_region[v]);
        uint32_t fv = cli_file_vertex(mesh, (uint32_t)v);
        if (ascii)
            fprintf(f, " %u %u %u %d %u\n", rgb[0], rgb[1], rgb[2], r, fv);
        else {
            fwrite(rgb, 1, 3, f);
            put_u32(f, (uint32_t)r);
            put_u32(f, fv);
        }
    }
    for (size_t t = 0; t < m; t++) {
        const uint32_t *c = tri + 3 * t;
        unsigned char rgb[3];
        cli_region_colour(seg->region[t], rgb);
        int32_t r = region_int(seg->region[t]);
        if (ascii)
            fprintf(f, "3 %u %u %u %d %u %u %u\n", c[0], c[1], c[2], r, rgb[0],
                    rgb[1], rgb[2]);
        else {
            fputc(3, f);
            for (int k = 0; k < 3; k++)
                put_u32(f, c[k]);
            put_u32(f, (uint32_t)r);
            fwrite(rgb, 1, 3, f);
        }
    }
    for (size_t i = 0; i < seg->count; i++) {
        uint32_t v = seg->maxima[i].vertex;
        put_xyz(f, xyz + 3 * (size_t)v, ascii);
        if (ascii)
            fprintf(f, " %zu %u %u\n", i, v, cli_file_vertex(mesh, v));
        else {
            put_u32(f, (uint32_t)i);
            put_u32(f, v);
            put_u32(f, cli_file_vertex(mesh, v));
        }
    }
}

static int save(const char *path, const phks_mesh *mesh,
                const segmentation *seg, int ascii)
{
    char *text = NULL;
    size_t size = 0;
    FILE *f = open_memstream(&text, &size);
    if (!f)
        return cli_error(path, strerror(errno));
    write_ply(f, mesh, seg, ascii);
    int bad = ferror(f);
    bad |= fclose(f) != 0;
    if (bad || cli_write_file_atomic(path, text, size) != 0) {
        free(text);
        return cli_error(path, strerror(errno ? errno : ENOMEM));
    }
    free(text);
    return 0;
}

static size_t *region_faces(const phks_mesh *mesh, const segmentation *seg)
{
    size_t m = phks_mesh_triangle_count(mesh);
    size_t *faces = calloc(seg->count + 1, sizeof *faces);
    for (size_t t = 0; faces && t < m; t++)
        if (seg->region[t] < seg->count)
            faces[seg->region[t]]++;
    return faces;
}

static void print_regions(const phks_mesh *mesh, const segmentation *seg)
{
    const double *xyz = phks_mesh_vertices(mesh);
    size_t *faces = region_faces(mesh, seg);
    printf("%6s %9s %8s %12s %12s %12s %12s %12s\n", "region", "triangles",
           "vertex", "x", "y", "z", "HKS", "persistence");
    for (size_t r = 0; r < seg->count; r++) {
        const phks_maximum *x = &seg->maxima[r];
        const double *p = xyz + 3 * (size_t)x->vertex;
        printf("%6zu %9zu %8u %12.6g %12.6g %12.6g %12.6g %12.6g\n", r,
               faces ? faces[r] : 0, cli_file_vertex(mesh, x->vertex), p[0],
               p[1], p[2], x->value, x->persistence);
    }
    free(faces);
}

static void json_regions(const char *path, const char *out,
                         const phks_mesh *mesh, const segmentation *seg,
                         size_t regions, double time, int ascii)
{
    const double *xyz = phks_mesh_vertices(mesh);
    size_t *faces = region_faces(mesh, seg);
    fputs("{\"file\": ", stdout);
    cli_json_string(path);
    fputs(", \"output\": ", stdout);
    cli_json_string(out);
    printf(", \"format\": \"%s\", \"vertices\": %zu, \"triangles\": %zu, "
           "\"time\": ", ascii ? "ascii" : "binary_little_endian",
           phks_mesh_vertex_count(mesh), phks_mesh_triangle_count(mesh));
    cli_json_number(time);
    printf(", \"max_regions\": %zu, \"region_count\": %zu,\n  \"regions\": [",
           regions, seg->count);
    for (size_t r = 0; r < seg->count; r++) {
        const phks_maximum *x = &seg->maxima[r];
        printf("%s\n    {\"region\": %zu, \"triangles\": %zu, \"vertex\": %u, "
               "\"position\": ", r ? "," : "", r, faces ? faces[r] : 0,
               cli_file_vertex(mesh, x->vertex));
        cli_json_vec(xyz + 3 * (size_t)x->vertex, 3);
        fputs(", \"hks\": ", stdout);
        cli_json_number(x->value);
        fputs(", \"persistence\": ", stdout);
        cli_json_number(x->persistence);
        fputs("}", stdout);
    }
    fputs("\n  ]\n}\n", stdout);
    free(faces);
}

int cli_segment(int argc, char **argv, const phks_options *options)
{
    const char *out = NULL, *regions_text = "15", *time_text = "5";
    int ascii = 0, json = 0, n;
    const cli_opt opts[] = {{"-o", &out, NULL},
                            {"--regions", &regions_text, NULL},
                            {"--time", &time_text, NULL},
                            {"--ascii", NULL, &ascii},
                            {"--json", NULL, &json}};
    unsigned long regions;
    if (cli_help(argc, argv, usage))
        return 0;
    double time;
    if (cli_parse(argc, argv, 1, opts, 5, &n) != 0 || n != 1 || !out ||
        cli_option_count("--regions", regions_text, 1, 100000, &regions) ||
        cli_option_time("--time", time_text, &time))
        return cli_usage(usage);
    if (!cli_has_suffix(out, ".ply"))
        return cli_error(out, "segment writes PLY only: name the output "
                              "OUT.ply");
    phks_mesh *mesh;
    if (cli_load_mesh(argv[1], &mesh) != 0)
        return 1;
    segmentation seg = {0};
    phks_status st = segment(mesh, options, regions, time, argv[1], &seg);
    int rc = st != PHKS_OK ? cli_fail(argv[1], st)
             : vertex_regions(mesh, &seg) != 0 ? cli_error(argv[1],
                                                           "out of memory")
                                              : save(out, mesh, &seg, ascii);
    if (rc == 0 && json)
        json_regions(argv[1], out, mesh, &seg, regions, time, ascii);
    else if (rc == 0) {
        printf("%s: %zu vertices, %zu triangles; %zu regions of HKS at "
               "t = %g tau\n", argv[1], phks_mesh_vertex_count(mesh),
               phks_mesh_triangle_count(mesh), seg.count, time);
        print_regions(mesh, &seg);
        printf("wrote %s\n", out);
    }
    free(seg.maxima);
    free(seg.region);
    free(seg.vertex_region);
    phks_mesh_free(mesh);
    return rc;
}
