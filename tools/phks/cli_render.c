/*
 * cli_render.c - `phks render MESH -o OUT.png`: the mesh's HKS regions in
 * the palette of `phks segment` with its feature points marked;
 * `phks render A B -o OUT.png`: both side by side, each of A's features
 * joined by a line to its nearest feature of B (phks_match).
 *
 * The regions are those `phks segment` computes (cli_segment.c): the
 * spectrum, the HKS at T tau and phks_persistent_maxima with at most N
 * maxima; the feature points are the signature's, from the same spectrum.
 */
#include "cli.h"
#include "render/cli_pictures.h"
#include "common/cli_common.h"

#include <stdlib.h>
#include <string.h>

typedef struct picture {
    const char *path;
    phks_mesh *mesh;
    phks_signature *sig;
    unsigned char *face_rgb;  /* 3 per triangle */
    size_t regions;
} picture;

static const char usage[] =
    "render MESH [MESH_B] -o OUT.png [--size WxH] [--regions N] [--time T]\n"
    "  -o OUT.png     the PNG to write (required; only PNG is written)\n"
    "  MESH_B         a second mesh, drawn beside MESH, each feature of MESH\n"
    "                 joined to its nearest feature of MESH_B\n"
    "  --size WxH     each mesh's tile, each side 16..4096 pixels (480x360)\n"
    "  --regions N    at most N regions, 1..100000 (15)\n"
    "  --time T       HKS time in units of tau, 0..1e9 (5)\n"
    "  global options: see `phks --help`";

/* The tile's sides. Below 16 pixels the feature markers (9 pixels across
 * at their smallest) would cover the shape; a 4096 x 4096 tile, drawn at
 * one sample per pixel (cli_view.c), takes 235 MB for its z-buffer,
 * samples and pixels. */
#define TILE_MIN 16
#define TILE_MAX 4096

typedef struct render_args {
    const char *out;
    int meshes;  /* 1 or 2: argv[1], argv[2] */
    int width, height;
    unsigned long regions;
    double time;
} render_args;

/* Prints "phks: what: reason" and the usage; returns 2. */
static int refuse(const char *what, const char *reason)
{
    cli_error(what, reason);
    return cli_usage(usage);
}

/* --size "WxH" into a; 0, or 2 after saying what is wrong. */
static int parse_size(const char *text, render_args *a)
{
    char *end, reason[256];
    unsigned long w = 0, h = 0;
    int shaped = *text >= '0' && *text <= '9';
    if (shaped) {
        w = strtoul(text, &end, 10);
        shaped = *end == 'x' && end[1] >= '0' && end[1] <= '9';
    }
    if (shaped) {
        h = strtoul(end + 1, &end, 10);
        shaped = !*end;
    }
    if (!shaped) {
        snprintf(reason, sizeof reason,
                 "'%s' is not WIDTHxHEIGHT in pixels (as 480x360)", text);
        return refuse("--size", reason);
    }
    if (w < TILE_MIN || h < TILE_MIN || w > TILE_MAX || h > TILE_MAX) {
        snprintf(reason, sizeof reason,
                 "%s: each side must be %d to %d pixels (below %d the "
                 "feature markers would cover the shape; a %dx%d tile "
                 "already takes 235 MB to draw)",
                 text, TILE_MIN, TILE_MAX, TILE_MIN, TILE_MAX, TILE_MAX);
        return refuse("--size", reason);
    }
    a->width = (int)w;
    a->height = (int)h;
    return 0;
}

/* --regions N into a; 0, or 2 after saying what is wrong. */
static int parse_regions(const char *text, render_args *a)
{
    char reason[160];
    if (cli_parse_count(text, 1, 100000, &a->regions) == 0)
        return 0;
    snprintf(reason, sizeof reason,
             "'%s' is not a whole number of regions from 1 to 100000", text);
    return refuse("--regions", reason);
}

/* --time T, in units of tau, into a; 0, or 2 after saying what is
 * wrong. */
static int parse_time(const char *text, render_args *a)
{
    char *end, reason[160];
    double t = strtod(text, &end);
    if (end != text && !*end && t >= 0 && t <= 1e9) {
        a->time = t;
        return 0;
    }
    snprintf(reason, sizeof reason,
             "'%s' is not a time from 0 to 1e9 (in units of tau)", text);
    return refuse("--time", reason);
}

/* render's command line into a (the meshes moved to argv[1..]): 0, or 2
 * after saying what is wrong. The defaults are the signature's own
 * feature_count and feature_scale. */
static int parse_args(int argc, char **argv, const phks_options *options,
                      render_args *a)
{
    const char *size = "480x360", *regions = NULL, *time = NULL;
    const cli_opt opts[] = {{"-o", &a->out, NULL}, {"--size", &size, NULL},
                            {"--regions", &regions, NULL},
                            {"--time", &time, NULL}};
    a->out = NULL;
    a->regions = options->feature_count;
    a->time = options->feature_scale;
    if (cli_parse(argc, argv, 1, opts, 4, &a->meshes) != 0)
        return cli_usage(usage);
    if (a->meshes < 1)
        return refuse("render", "no mesh to draw");
    if (a->meshes > 2)
        return refuse("render", "more than two meshes: render draws one, "
                                "or two side by side");
    if (!a->out)
        return refuse("render", "no output: -o OUT.png names the picture");
    if (parse_size(size, a) != 0 || (regions && parse_regions(regions, a)) ||
        (time && parse_time(time, a)))
        return 2;
    return 0;
}

/* Spectrum, regions of HKS at time * tau (at most regions of them) and the
 * signature, into pic. */
static phks_status compute(picture *pic, const phks_options *o,
                           size_t regions, double time)
{
    const phks_mesh *mesh = pic->mesh;
    size_t n = phks_mesh_vertex_count(mesh), m = phks_mesh_triangle_count(mesh);
    size_t cap = regions < m ? regions : m;
    phks_spectrum *spec = NULL;
    double *hks = malloc(n * sizeof *hks);
    phks_maximum *maxima = malloc(cap * sizeof *maxima);
    uint32_t *region = malloc(m * sizeof *region);
    pic->face_rgb = malloc(3 * m);
    phks_status st = hks && maxima && region && pic->face_rgb
                         ? phks_spectrum_compute(mesh, o, &spec)
                         : PHKS_ERROR_OUT_OF_MEMORY;
    if (st == PHKS_OK)
        st = phks_spectrum_hks(spec, time * o->tau, hks);
    if (st == PHKS_OK)
        st = phks_persistent_maxima(mesh, hks, regions, 0.0, maxima,
                                    &pic->regions, region);
    if (st == PHKS_OK)
        st = phks_signature_from_spectrum(mesh, spec, o, &pic->sig);
    for (size_t t = 0; st == PHKS_OK && t < m; t++)
        cli_region_colour(region[t], pic->face_rgb + 3 * t);
    phks_spectrum_free(spec);
    free(hks);
    free(maxima);
    free(region);
    return st;
}

static void picture_free(picture *pic)
{
    phks_mesh_free(pic->mesh);
    phks_signature_free(pic->sig);
    free(pic->face_rgb);
}

static double marker_radius(int w, int h)
{
    int s = w < h ? w : h;
    return s / 90.0 > 3 ? s / 90.0 : 3;
}

static void draw_markers(cli_image *im, const cli_view *view,
                         const phks_signature *sig, double radius)
{
    for (size_t i = 0; i < phks_signature_feature_count(sig); i++) {
        double p[3];
        phks_signature_feature_position(sig, i, p);
        cli_draw_marker(im, view, p, radius);
    }
}

/* The file name without its folders, cut to fit width, at the tile's
 * bottom left. */
static void caption(cli_image *im, int x, int y, int w, int h, const char *text)
{
    static const unsigned char ink[3] = {60, 60, 60};
    const char *base = strrchr(text, '/');
    char buf[128];
    cli_text_fit(buf, sizeof buf, base ? base + 1 : text, w - 8, 1);
    cli_draw_text(im, x + 4, y + h - CLI_FONT_HEIGHT - 4, buf, 1, ink);
}

static int draw_one(cli_image *im, const picture *pic)
{
    cli_view view;
    if (cli_draw_mesh(im, 0, 0, im->width, im->height, pic->mesh,
                      pic->face_rgb, &view) != 0)
        return -1;
    draw_markers(im, &view, pic->sig, marker_radius(im->width, im->height));
    cli_view_free(&view);
    return 0;
}

/* A's tile on the left, B's on the right, each of A's features joined to
 * its nearest of B, the lines under the markers. */
static int draw_match(cli_image *im, const picture pic[2], double *score)
{
    size_t na = phks_signature_feature_count(pic[0].sig);
    size_t nb = phks_signature_feature_count(pic[1].sig), count = 0;
    phks_correspondence *c = malloc((na + nb + 1) * sizeof *c);
    int w = im->width / 2, h = im->height;
    cli_view view[2];
    if (!c)
        return -1;
    phks_status st = phks_match(pic[0].sig, pic[1].sig, c, na + nb, &count,
                                score);
    if (st != PHKS_OK) {
        free(c);
        return cli_fail(pic[1].path, st);
    }
    for (int s = 0; s < 2; s++)
        if (cli_draw_mesh(im, s * w, 0, w, h, pic[s].mesh, pic[s].face_rgb,
                          &view[s]) != 0) {
            if (s)
                cli_view_free(&view[0]);
            free(c);
            return -1;
        }
    static const unsigned char white[3] = {255, 255, 255};
    double r = marker_radius(w, h);
    for (size_t i = 0; i < count; i++) {
        if (!c[i].from_a)
            continue;
        double pa[3], pb[3], xa, ya, xb, yb;
        unsigned char rgb[3];
        phks_signature_feature_position(pic[0].sig, c[i].feature_a, pa);
        phks_signature_feature_position(pic[1].sig, c[i].feature_b, pb);
        cli_view_project(&view[0], pa, &xa, &ya);
        cli_view_project(&view[1], pb, &xb, &yb);
        cli_region_colour((uint32_t)c[i].feature_a, rgb);
        cli_draw_line(im, xa, ya, xb, yb, r * 0.9 + 2, white);
        cli_draw_line(im, xa, ya, xb, yb, r * 0.9, rgb);
    }
    for (int s = 0; s < 2; s++) {
        draw_markers(im, &view[s], pic[s].sig, r);
        caption(im, s * w, 0, w, h, pic[s].path);
        cli_view_free(&view[s]);
    }
    free(c);
    return 0;
}

int cli_render(int argc, char **argv, const phks_options *options)
{
    render_args a;
    if (cli_help(argc, argv, usage))
        return 0;
    int bad = parse_args(argc, argv, options, &a);
    if (bad)
        return bad;
    /* The picture is a PNG whatever its name; under another one (.jpg)
     * viewers and converters that go by the name misread it. */
    if (!cli_has_suffix(a.out, ".png"))
        return cli_error(a.out, "render writes PNG only: name the output "
                                "OUT.png");
    if (!cli_png_supported())
        return cli_png_write(a.out, NULL);
    picture pic[2] = {{0}};
    int rc = 0;
    for (int i = 0; i < a.meshes && rc == 0; i++) {
        pic[i].path = argv[1 + i];
        if (cli_is_blob(pic[i].path)) {
            rc = cli_error(pic[i].path, "a signature blob: no mesh to draw");
            break;
        }
        if (cli_load_mesh(pic[i].path, &pic[i].mesh) != 0) {
            rc = 1;
            break;
        }
        phks_status st = compute(&pic[i], options, a.regions, a.time);
        if (st != PHKS_OK)
            rc = cli_fail(pic[i].path, st);
    }
    cli_image im = {0};
    double score = 0;
    if (rc == 0 && cli_image_init(&im, a.meshes * a.width, a.height) != 0)
        rc = cli_error(a.out, "out of memory");
    if (rc == 0) {
        int drawn = a.meshes == 1 ? draw_one(&im, &pic[0]) : draw_match(&im, pic, &score);
        rc = drawn < 0 ? cli_error(a.out, "out of memory") : drawn;
    }
    if (rc == 0)
        rc = cli_png_write(a.out, &im);
    if (rc == 0) {
        for (int i = 0; i < a.meshes; i++)
            printf("%s: %zu regions of HKS at t = %g tau, %zu features\n",
                   pic[i].path, pic[i].regions, a.time,
                   phks_signature_feature_count(pic[i].sig));
        if (a.meshes == 2)
            printf("score %g\n", score);
        printf("wrote %s (%dx%d)\n", a.out, im.width, im.height);
    }
    cli_image_free(&im);
    for (int i = 0; i < a.meshes; i++)
        picture_free(&pic[i]);
    return rc;
}
