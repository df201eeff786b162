/*
 * cli_render.c - `phks render MESH -o OUT.png`: the mesh's HKS regions in
 * the palette of `phks segment` with its feature points marked;
 * `phks render A B -o OUT.png`: both side by side with the pairs of
 * phks_match (render/cli_pairs.c): lines with a dot at both ends, the
 * verified ones solid, B's regions in the colours of the A regions its
 * pairs come from, and the score with the verified share in the caption.
 *
 * The regions are those `phks segment` computes (cli_segment.c): the
 * spectrum, the HKS at T tau and phks_persistent_maxima with at most N
 * maxima; the feature points are the signature's, from the same spectrum.
 */
#include "cli.h"
#include "render/cli_pictures.h"
#include "common/cli_common.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char usage[] =
    "render MESH [MESH_B] -o OUT.png [--size WxH] [--regions N]\n"
    "                   [--time T] [--pairs verified|all|none]\n"
    "                   [--view AZ,EL] [--up x|y|z|-x|-y|-z] [--json]\n"
    "  -o OUT.png     the PNG to write (required; only PNG is written)\n"
    "  MESH_B         a second mesh, drawn beside MESH with the pairs of\n"
    "                 phks_match\n"
    "  --size WxH     each mesh's tile, each side 16..4096 pixels (480x360)\n"
    "  --regions N    at most N regions, 1..100000 (15)\n"
    "  --time T       HKS time of the regions in units of tau, above 0, at\n"
    "                 most 1e9 (5)\n"
    "  --pairs P      the pairs of A B drawn: verified, all (the others\n"
    "                 faint) or none (verified)\n"
    "  --view AZ,EL   turned AZ degrees about the up axis, seen from EL\n"
    "                 degrees above, -90..90 (30,20)\n"
    "  --up AXIS      the file's axis upright (the longest principal axis)\n"
    "  --json         print what was drawn as JSON (text)\n"
    "  global options: see `phks --help`";

/* The command line, parsed. */
typedef struct render_request {
    const char *out;
    int w, h;  /* one tile */
    unsigned long regions;
    double time;
    cli_pairs_shown pairs;
    cli_view_options view;
    int json;
} render_request;

/* What a two-mesh picture shows, for its caption and the printout. */
typedef struct match_result {
    double score;
    size_t verified, features;  /* A's rows of phks_match verified, of all */
    int nearest;                /* the matching verifies nothing           */
    cli_pair *pairs;
    size_t pair_count;
} match_result;

/* The tile's sides. Below 16 pixels the feature markers (9 pixels across
 * at their smallest) would cover the shape; a 4096 x 4096 tile, drawn at
 * one sample per pixel (cli_view.c), takes 235 MB for its z-buffer,
 * samples and pixels. */
#define TILE_MIN 16
#define TILE_MAX 4096

/* Prints "phks: what: reason" and the usage; returns 2. */
static int refuse(const char *what, const char *reason)
{
    cli_error(what, reason);
    return cli_usage(usage);
}

/* --size "WxH" into r; 0, or 2 after saying what is wrong. */
static int parse_size(const char *text, render_request *r)
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
    r->w = (int)w;
    r->h = (int)h;
    return 0;
}

/* "AZ,EL" in degrees, AZ in -360..360 and EL in -90..90; 0, or -1. */
static int parse_view(const char *text, cli_view_options *o)
{
    char *end;
    double az = strtod(text, &end);
    if (end == text || *end != ',')
        return -1;
    const char *second = end + 1;
    double el = strtod(second, &end);
    if (end == second || *end || !(fabs(az) <= 360) || !(fabs(el) <= 90))
        return -1;
    o->angles_given = 1;
    o->azimuth = az;
    o->elevation = el;
    return 0;
}

/* "x", "y", "z" or one of them after '-', as cli_view_options.up; 0, or
 * -1. */
static int parse_up(const char *text, int *up)
{
    int negative = *text == '-';
    const char *axis = text + negative;
    if (!*axis || axis[1] || !strchr("xyz", *axis))
        return -1;
    *up = (*axis - 'x' + 1) * (negative ? -1 : 1);
    return 0;
}

static int parse_pairs(const char *text, cli_pairs_shown *shown)
{
    static const char *const names[] = {"verified", "all", "none"};
    for (int i = 0; i < 3; i++)
        if (strcmp(text, names[i]) == 0) {
            *shown = (cli_pairs_shown)i;
            return 0;
        }
    return -1;
}

/* The command line into r (the meshes moved to argv[1..n]): 0, or 2
 * after saying what is wrong. The defaults are the signature's own
 * feature_count and feature_scale. */
static int parse_request(int argc, char **argv, const phks_options *options,
                         render_request *r, int *n)
{
    const char *size = "480x360", *regions = NULL, *time = NULL, *pairs = NULL,
               *view = NULL, *up = NULL;
    const cli_opt opts[] = {
        {"-o", &r->out, NULL},         {"--size", &size, NULL},
        {"--regions", &regions, NULL}, {"--time", &time, NULL},
        {"--pairs", &pairs, NULL},     {"--view", &view, NULL},
        {"--up", &up, NULL},           {"--json", NULL, &r->json}};
    r->regions = options->feature_count;
    r->time = options->feature_scale;
    r->pairs = CLI_PAIRS_VERIFIED;
    if (cli_parse(argc, argv, 1, opts, sizeof opts / sizeof opts[0], n) != 0)
        return cli_usage(usage);
    if (*n < 1)
        return refuse("render", "no mesh to draw");
    if (*n > 2)
        return refuse("render", "more than two meshes: render draws one, "
                                "or two side by side");
    if (!r->out)
        return refuse("render", "no output: -o OUT.png names the picture");
    if (parse_size(size, r) != 0)
        return 2;
    if ((regions &&
         cli_option_count("--regions", regions, 1, 100000, &r->regions)) ||
        (time && cli_option_time("--time", time, &r->time)))
        return cli_usage(usage);
    if (pairs && parse_pairs(pairs, &r->pairs) != 0)
        return refuse("--pairs", "one of verified, all or none");
    if (view && parse_view(view, &r->view) != 0)
        return refuse("--view", "AZ,EL in degrees, AZ -360..360 and EL "
                                "-90..90 (as 30,20)");
    if (up && parse_up(up, &r->view.up) != 0)
        return refuse("--up", "one of x, y, z, -x, -y or -z");
    return 0;
}

/* Spectrum, regions of HKS at time * tau (at most regions of them), each
 * vertex's region, each region's maximum and the signature, into s. */
static phks_status compute(cli_shape *s, const phks_options *o,
                           size_t regions, double time)
{
    const phks_mesh *mesh = s->mesh;
    size_t n = phks_mesh_vertex_count(mesh), m = phks_mesh_triangle_count(mesh);
    size_t cap = regions < m ? regions : m;
    phks_spectrum *spec = NULL;
    double *hks = malloc(n * sizeof *hks);
    phks_maximum *maxima = malloc(cap * sizeof *maxima);
    s->region = malloc(m * sizeof *s->region);
    s->vertex_region = malloc(n * sizeof *s->vertex_region);
    s->peak = malloc(cap * sizeof *s->peak);
    phks_status st = hks && maxima && s->region && s->vertex_region && s->peak
                         ? phks_spectrum_compute(mesh, o, &spec)
                         : PHKS_ERROR_OUT_OF_MEMORY;
    if (st == PHKS_OK)
        st = phks_spectrum_hks(spec, time * o->tau, hks);
    if (st == PHKS_OK)
        st = phks_persistent_maxima(mesh, hks, regions, 0.0, maxima,
                                    &s->regions, s->region);
    if (st == PHKS_OK && cli_vertex_regions(mesh, s->region,
                                            s->vertex_region) != 0)
        st = PHKS_ERROR_OUT_OF_MEMORY;
    for (size_t r = 0; st == PHKS_OK && r < s->regions; r++)
        s->peak[r] = maxima[r].vertex;
    if (st == PHKS_OK)
        st = phks_signature_from_spectrum(mesh, spec, o, &s->sig);
    phks_spectrum_free(spec);
    free(hks);
    free(maxima);
    return st;
}

static void shape_free(cli_shape *s)
{
    phks_mesh_free(s->mesh);
    phks_signature_free(s->sig);
    free(s->region);
    free(s->vertex_region);
    free(s->peak);
}

/* Each triangle's colour: its region's in region_rgb (3 per region), or
 * the palette's when region_rgb is NULL. NULL when out of memory. */
static unsigned char *face_colours(const cli_shape *s,
                                   const unsigned char *region_rgb)
{
    size_t m = phks_mesh_triangle_count(s->mesh);
    unsigned char *rgb = malloc(m ? 3 * m : 1);
    for (size_t t = 0; rgb && t < m; t++) {
        uint32_t r = s->region[t];
        if (region_rgb && r != UINT32_MAX)
            memcpy(rgb + 3 * t, region_rgb + 3 * (size_t)r, 3);
        else
            cli_region_colour(r, rgb + 3 * t);
    }
    return rgb;
}

/* Draws s's mesh into its tile, faces coloured as face_colours says. 0,
 * or -1 when out of memory. */
static int draw_shape(cli_image *im, const int tile[4], const cli_shape *s,
                      const unsigned char *region_rgb,
                      const cli_view_options *o, cli_view *view)
{
    unsigned char *rgb = face_colours(s, region_rgb);
    int rc = rgb ? cli_draw_mesh(im, tile[0], tile[1], tile[2], tile[3],
                                 s->mesh, rgb, o, view)
                 : -1;
    free(rgb);
    return rc;
}

static double marker_radius(int w, int h)
{
    int s = w < h ? w : h;
    return s / 90.0 > 3 ? s / 90.0 : 3;
}

/* ---- captions ------------------------------------------------------------ */

/* The caption band under the tiles: text a capital h / 40 high (at least
 * 7 pixels), so that it keeps its share of the picture at any size, on
 * lines 1.6 of that apart. Tiles under 64 pixels high have none: their
 * text could not be read. */
typedef struct band {
    double size;
    int height;
} band;

static band caption_band(int h, int lines)
{
    band b = {0, 0};
    if (h >= 64) {
        b.size = fmax(7, h / 40.0);
        b.height = (int)ceil((1.6 * lines + 0.6) * b.size);
    }
    return b;
}

/* Line `line` of the band under the tile at x (width w), cut to fit. */
static int caption(cli_image *im, const band *b, int line, int x, int w,
                   const char *text)
{
    static const unsigned char ink[3] = {60, 60, 60};
    char buf[256];
    double pad = b->size / 2;
    double baseline = im->height - b->height + (1.6 * line + 1.3) * b->size;
    if (b->height == 0)
        return 0;
    cli_text_fit(buf, sizeof buf, text, w - 2 * pad, b->size);
    return cli_draw_text(im, x + pad, baseline, buf, b->size, ink);
}

static const char *file_name(const char *path)
{
    const char *slash = strrchr(path, '/');
    return slash ? slash + 1 : path;
}

/* "score 12.3, 12 of 15 verified", digits significant. */
static void score_text(char *buf, size_t size, const match_result *m,
                       int digits)
{
    if (m->nearest)
        snprintf(buf, size, "score %.*g, nearest vectors (none verified)",
                 digits, m->score);
    else
        snprintf(buf, size, "score %.*g, %zu of %zu verified", digits,
                 m->score, m->verified, m->features);
}

/* ---- the pictures --------------------------------------------------------- */

static int draw_one(cli_image *im, const cli_shape *s, const render_request *r,
                    cli_view *view)
{
    band b = caption_band(im->height, 1);
    int tile[4] = {0, 0, im->width, im->height - b.height};
    if (draw_shape(im, tile, s, NULL, &r->view, view) != 0)
        return -1;
    double radius = marker_radius(tile[2], tile[3]);
    for (size_t i = 0; i < phks_signature_feature_count(s->sig); i++) {
        double p[3];
        phks_signature_feature_position(s->sig, i, p);
        cli_draw_marker(im, view, p, radius);
    }
    return caption(im, &b, 0, 0, im->width, file_name(s->path));
}

/* phks_match of A and B into m (its pairs as r->pairs says). 0, or 1
 * after a message. */
static int match(const cli_shape s[2], const render_request *r,
                 match_result *m)
{
    size_t na = phks_signature_feature_count(s[0].sig);
    size_t nb = phks_signature_feature_count(s[1].sig), count = 0;
    phks_correspondence *c = malloc((na + nb + 1) * sizeof *c);
    phks_options used;
    m->pairs = malloc((na + 1) * sizeof *m->pairs);
    if (!c || !m->pairs) {
        free(c);
        return cli_error(r->out, "out of memory");
    }
    phks_status st = phks_match(s[0].sig, s[1].sig, c, na + nb, &count,
                                &m->score);
    if (st != PHKS_OK) {
        free(c);
        return cli_fail(s[1].path, st);
    }
    phks_signature_options(s[0].sig, &used);
    m->nearest = used.matching == PHKS_MATCHING_NEAREST;
    m->features = na;
    for (size_t i = 0; i < count; i++)
        m->verified += c[i].from_a && c[i].verified;
    m->pair_count = cli_pairs_pick(c, count, r->pairs, &s[0], m->pairs);
    free(c);
    return 0;
}

/* A's tile on the left, B's on the right, B's regions in the colours of
 * the pairs that end in them. 0, or -1 when out of memory. */
static int draw_two(cli_image *im, const cli_shape s[2],
                    const render_request *r, match_result *m,
                    cli_view view[2])
{
    band b = caption_band(im->height, 2);
    int w = im->width / 2, h = im->height - b.height;
    unsigned char *b_rgb = malloc(s[1].regions ? 3 * s[1].regions : 1);
    if (!b_rgb)
        return -1;
    cli_pairs_colour_regions(m->pairs, m->pair_count, &s[1], b_rgb);
    int rc = 0;
    for (int i = 0; i < 2 && rc == 0; i++) {
        int tile[4] = {i * w, 0, w, h};
        rc = draw_shape(im, tile, &s[i], i ? b_rgb : NULL, &r->view, &view[i]);
    }
    free(b_rgb);
    if (rc != 0)
        return -1;
    cli_pairs_draw(im, m->pairs, m->pair_count, s, view, marker_radius(w, h));
    char text[128];
    score_text(text, sizeof text, m, 4);
    rc = caption(im, &b, 0, 0, w, file_name(s[0].path));
    if (rc == 0)
        rc = caption(im, &b, 0, w, w, file_name(s[1].path));
    if (rc == 0)
        rc = caption(im, &b, 1, 0, im->width, text);
    return rc;
}

/* ---- what was drawn, on stdout -------------------------------------------- */

static void print_text(const render_request *r, const cli_shape *s, int n,
                       const match_result *m, const cli_image *im)
{
    for (int i = 0; i < n; i++)
        printf("%s: %zu regions of HKS at t = %g tau, %zu features\n",
               s[i].path, s[i].regions, r->time,
               phks_signature_feature_count(s[i].sig));
    if (n == 2) {
        char text[128];
        score_text(text, sizeof text, m, 6);
        printf("%s\n", text);
    }
    printf("wrote %s (%dx%d)\n", r->out, im->width, im->height);
}

static void json_point(const char *name, double x, double y, int visible)
{
    double p[2] = {x, y};
    printf(", \"%s\": ", name);
    cli_json_vec(p, 2);
    printf(", \"%s_visible\": %s", name, visible ? "true" : "false");
}

static void json_pairs(const cli_shape *s, const match_result *m)
{
    size_t nb = phks_signature_feature_count(s[1].sig);
    fputs(",\n  \"score\": ", stdout);
    cli_json_number(m->score);
    printf(", \"verified\": %zu, \"features_a\": %zu, \"pairs\": [",
           m->verified, m->features);
    for (size_t k = 0; k < m->pair_count; k++) {
        const cli_pair *p = &m->pairs[k];
        printf("%s\n    {\"feature_a\": %u, \"point_b\": %u, "
               "\"b_is_sample\": %s, \"verified\": %s, \"distance\": ",
               k ? "," : "", p->feature_a, p->point_b,
               p->point_b >= nb ? "true" : "false",
               p->verified ? "true" : "false");
        cli_json_number(p->distance);
        printf(", \"rgb\": [%d, %d, %d]", p->rgb[0], p->rgb[1], p->rgb[2]);
        json_point("a", p->ax, p->ay, p->a_visible);
        json_point("b", p->bx, p->by, p->b_visible);
        fputs("}", stdout);
    }
    fputs("\n  ]", stdout);
}

static void print_json(const render_request *r, const cli_shape *s, int n,
                       const match_result *m, const cli_image *im,
                       const cli_view *view)
{
    static const char *const pairs[] = {"verified", "all", "none"};
    fputs("{\"output\": ", stdout);
    cli_json_string(r->out);
    printf(", \"width\": %d, \"height\": %d, \"pairs_shown\": \"%s\", "
           "\"time\": ", im->width, im->height, pairs[r->pairs]);
    cli_json_number(r->time);
    fputs(",\n  \"meshes\": [", stdout);
    for (int i = 0; i < n; i++) {
        const cli_view *v = &view[i];
        printf("%s\n    {\"file\": ", i ? "," : "");
        cli_json_string(s[i].path);
        printf(", \"regions\": %zu, \"features\": %zu, \"samples\": %zu, "
               "\"boundary_edges\": %zu, \"tile\": [%d, %d, %d, %d], "
               "\"azimuth\": ", s[i].regions,
               phks_signature_feature_count(s[i].sig),
               phks_signature_sample_count(s[i].sig),
               phks_mesh_boundary_edge_count(s[i].mesh), v->x, v->y, v->w,
               v->h);
        cli_json_number(v->azimuth);
        fputs(", \"elevation\": ", stdout);
        cli_json_number(v->elevation);
        fputs("}", stdout);
    }
    fputs("\n  ]", stdout);
    if (n == 2)
        json_pairs(s, m);
    fputs("\n}\n", stdout);
}

/* ---- the command ------------------------------------------------------------ */

/* Loads and computes the n meshes of argv[1..n]; 0, or 1 after a
 * message. */
static int load(cli_shape *s, int n, char **argv, const phks_options *o,
                const render_request *r)
{
    for (int i = 0; i < n; i++) {
        s[i].path = argv[1 + i];
        if (cli_is_blob(s[i].path))
            return cli_error(s[i].path, "a signature blob: no mesh to draw");
        if (cli_load_mesh(s[i].path, &s[i].mesh) != 0)
            return 1;
        phks_status st = compute(&s[i], o, r->regions, r->time);
        if (st != PHKS_OK)
            return cli_fail(s[i].path, st);
    }
    return 0;
}

int cli_render(int argc, char **argv, const phks_options *options)
{
    render_request r = {0};
    int n;
    if (cli_help(argc, argv, usage))
        return 0;
    int bad = parse_request(argc, argv, options, &r, &n);
    if (bad)
        return bad;
    /* The picture is a PNG whatever its name; under another one (.jpg)
     * viewers and converters that go by the name misread it. */
    if (!cli_has_suffix(r.out, ".png"))
        return cli_error(r.out, "render writes PNG only: name the output "
                                "OUT.png");
    if (!cli_png_supported())
        return cli_png_write(r.out, NULL);
    cli_shape s[2] = {{0}};
    match_result m = {0};
    cli_view view[2];
    cli_image im = {0};
    memset(view, 0, sizeof view);  /* freed whatever was drawn */
    int rc = load(s, n, argv, options, &r);
    if (rc == 0 && n == 2)
        rc = match(s, &r, &m);
    if (rc == 0 && cli_image_init(&im, n * r.w, r.h) != 0)
        rc = cli_error(r.out, "out of memory");
    if (rc == 0 && (n == 1 ? draw_one(&im, &s[0], &r, &view[0])
                           : draw_two(&im, s, &r, &m, view)) != 0)
        rc = cli_error(r.out, "out of memory");
    if (rc == 0)
        rc = cli_png_write(r.out, &im);
    if (rc == 0 && r.json)
        print_json(&r, s, n, &m, &im, view);
    else if (rc == 0)
        print_text(&r, s, n, &m, &im);
    cli_image_free(&im);
    for (int i = 0; i < n; i++) {
        cli_view_free(&view[i]);
        shape_free(&s[i]);
    }
    free(m.pairs);
    return rc;
}
