/*
 * cli_pictures.h - pictures of meshes for `phks render` (../cli_render.c)
 * and `phks db query --png` (docs/cli.md): a software rasteriser, a stroke
 * font and PNG output, all deterministic (the same bytes every run).
 *
 *   cli_raster.c   RGB images: rectangles, discs, lines, downsampling
 *   cli_font.c     the stroke font of captions, at any size
 *   cli_frame.c    which way a mesh is seen: its frame, azimuth, elevation
 *   cli_view.c     a mesh's z-buffered, Lambert-shaded drawing with its
 *                  boundary edges; feature markers
 *   cli_regions.c  the region palette; each vertex's region
 *   cli_pairs.c    a match's pairs: which are drawn, their colours, B's
 *                  regions in A's colours, lines and end dots
 *   cli_png.c      PNG encoding through libspng (optional)
 *   cli_sheet.c    the contact sheet of `db query --png`
 */
#ifndef PHKS_CLI_PICTURES_H
#define PHKS_CLI_PICTURES_H

#include "phks.h"

#include <stddef.h>

/* ---- images (cli_raster.c) ---------------------------------------------- */
typedef struct cli_image {
    int width, height;
    unsigned char *rgb;  /* width * height * 3 bytes, rows top to bottom */
} cli_image;

/* A white image; 0, or -1 when out of memory (im->rgb NULL). */
int cli_image_init(cli_image *im, int width, int height);
void cli_image_free(cli_image *im);
/* Everything is clipped to the image. */
void cli_fill_rect(cli_image *im, int x, int y, int w, int h,
                   const unsigned char rgb[3]);
/* Pixels whose centre is within r of (cx, cy). */
void cli_draw_disc(cli_image *im, double cx, double cy, double r,
                   const unsigned char rgb[3]);
/* Pixels whose centre is within r of the segment and farther than
 * r - width from (cx, cy): a ring. */
void cli_draw_ring(cli_image *im, double cx, double cy, double r,
                   double width, const unsigned char rgb[3]);
/* Pixels whose centre is within width / 2 of the segment. */
void cli_draw_line(cli_image *im, double x0, double y0, double x1, double y1,
                   double width, const unsigned char rgb[3]);
/* A one-pixel frame around the rectangle's inside edge. */
void cli_draw_frame(cli_image *im, int x, int y, int w, int h,
                    const unsigned char rgb[3]);
/* src (factor * w by factor * h) averaged in factor x factor blocks into
 * dst at (x, y), rounding half up. */
void cli_downsample(cli_image *dst, int x, int y, const cli_image *src,
                    int factor);
/* rgb laid over dst at (x, y) through mask (factor * w by factor * h, drawn
 * dark on white): each pixel takes rgb in the share of its block that is
 * dark, the anti-aliasing of the stroke font. */
void cli_blend_mask(cli_image *dst, int x, int y, const cli_image *mask,
                    int factor, const unsigned char rgb[3]);

/* ---- text (cli_font.c) --------------------------------------------------- */
/* One line of text in the stroke font; size is a capital's height in
 * pixels (any size; descenders reach size / 3 below the baseline). The
 * width it takes, in pixels: */
double cli_text_width(const char *text, double size);
/* Draws text from x with its baseline at y, anti-aliased. 0, or -1 when
 * out of memory. */
int cli_draw_text(cli_image *im, double x, double baseline, const char *text,
                  double size, const unsigned char rgb[3]);
/* Cuts text (a copy in buf, size bytes) to fit width pixels at text_size,
 * ending in ".." when cut; returns buf. */
char *cli_text_fit(char *buf, size_t size, const char *text, double width,
                   double text_size);

/* ---- a mesh's view (cli_frame.c) and drawing (cli_view.c) ------------------ */
/* How a mesh is seen (NULL: every default).
 * up: 0 for the mesh's own frame: centred on its area centroid, its
 *   principal axes (of the area-weighted second moments) upright the
 *   largest, the surface's third moment along it made not positive, the
 *   smallest towards the viewer, its third moment made not negative;
 *   right-handed, so never a mirror image. Then the largest open boundary
 *   (the connected boundary edges of greatest length) goes to the far
 *   side: the up axis is turned over when its centre lies above the
 *   mesh's, and the front turned away from it when it lies beside, each
 *   by more than 5% of the surface's RMS radius.
 *   1, 2, 3 (-1, -2, -3) for the file's +x, +y, +z (-x, -y, -z) upright,
 *   the front +y, +z, -y respectively (the modelling programs' front
 *   views: OpenGL's +z for y up, CAD's -y for z up).
 * azimuth, elevation (degrees, when angles_given): the mesh turned about
 *   its up axis, its front going right, then seen from that far above
 *   (below when negative); otherwise 30 and 20. Then projected
 *   orthographically to fill 90% of the tile. */
typedef struct cli_view_options {
    int up;
    int angles_given;
    double azimuth, elevation;
} cli_view_options;

typedef struct cli_view {
    double centre[3];
    double rot[3][3];  /* rows: screen right, screen up, towards viewer */
    double azimuth, elevation;  /* degrees, as used                    */
    double scale;      /* pixels per input unit                          */
    double ox, oy;     /* pixel position of the projected centre          */
    int x, y, w, h;    /* the tile, in the image                          */
    int ss;            /* samples per pixel along each axis               */
    double *depth;     /* the tile's z-buffer (ss w by ss h), after drawing */
} cli_view;

/* Sets view's centre, rotation and angles for mesh (cli_frame.c). 0, or
 * -1 when out of memory. */
int cli_view_orient(cli_view *view, const phks_mesh *mesh,
                    const cli_view_options *options);
/* Draws mesh into the tile (x, y, w, h) of im: each triangle flat-shaded,
 * colour face_rgb[3 t..] (NULL: light grey) times 0.35 + 0.65 |n . l|
 * (two-sided Lambert, l from the upper left front), with a z-buffer,
 * rendered at 3x3 samples per pixel (fewer on tiles above 1.7M pixels)
 * and averaged down; the boundary edges (one triangle each) over it in
 * cli_boundary_rgb, where the surface does not hide them. view receives
 * the projection; free it with cli_view_free. 0, or -1 when out of
 * memory. */
int cli_draw_mesh(cli_image *im, int x, int y, int w, int h,
                  const phks_mesh *mesh, const unsigned char *face_rgb,
                  const cli_view_options *options, cli_view *view);
void cli_view_free(cli_view *view);
/* The image position of p (input coordinates), and whether it is in front
 * of the drawn surface (1) or hidden behind it (0). */
int cli_view_project(const cli_view *view, const double p[3], double *px,
                     double *py);

/* Feature point markers: a black disc in a white ring when the point is
 * visible, a black ring when the surface hides it. radius in pixels. */
void cli_draw_marker(cli_image *im, const cli_view *view, const double p[3],
                     double radius);
extern const unsigned char cli_marker_rgb[3];    /* 0 0 0    */
extern const unsigned char cli_boundary_rgb[3];  /* 20 20 20 */

/* ---- regions (cli_regions.c) -------------------------------------------- */
/* Region colours: Kelly's contrast colours, then golden-angle hues; grey
 * for UINT32_MAX (no region). The same palette as `phks segment`. */
void cli_region_colour(uint32_t region, unsigned char rgb[3]);
/* Each vertex's region: that of most of its triangles (region, one per
 * triangle), ties to the lower; UINT32_MAX only when it has no other.
 * 0, or -1 when out of memory. */
int cli_vertex_regions(const phks_mesh *mesh, const uint32_t *region,
                       uint32_t *vertex_region);

/* ---- a match's pairs (cli_pairs.c) ---------------------------------------- */
/* Which of phks_match's pairs a picture draws: the verified ones, all of
 * A's rows (the unverified faint), or none. */
typedef enum cli_pairs_shown {
    CLI_PAIRS_VERIFIED,
    CLI_PAIRS_ALL,
    CLI_PAIRS_NONE
} cli_pairs_shown;

/* A mesh as `phks render` draws it: its HKS regions and its signature. */
typedef struct cli_shape {
    const char *path;
    phks_mesh *mesh;
    phks_signature *sig;
    uint32_t *region;         /* per triangle; UINT32_MAX: none */
    uint32_t *vertex_region;  /* per vertex (cli_vertex_regions) */
    uint32_t *peak;           /* per region, its maximum's vertex */
    size_t regions;
} cli_shape;

/* One drawn pair: A's feature and the point of B phks_match pairs it
 * with (a feature of B, or one of B's samples when point_b is at least
 * B's feature count). */
typedef struct cli_pair {
    uint32_t feature_a, point_b;
    int verified;
    double distance;        /* of their HKS vectors (phks_correspondence) */
    unsigned char rgb[3];   /* the colour of A's region at feature_a      */
    double ax, ay, bx, by;  /* the ends in the image (cli_pairs_draw)     */
    int a_visible, b_visible;
} cli_pair;

/* The pairs to draw among phks_match's count rows c: A's rows, verified
 * or all or none as shown says, into out (room for A's feature count).
 * Returns their number. */
size_t cli_pairs_pick(const phks_correspondence *c, size_t count,
                      cli_pairs_shown shown, const cli_shape *a,
                      cli_pair *out);
/* B's region colours (3 per region into region_rgb) from the pairs: a
 * region takes the colour of the best pair that ends in it, those at its
 * maximum first (the point the region grew from, most often a feature),
 * then verified ones, then the nearer vectors, then the lower feature of
 * A; so a body part has one colour on both sides. A region no pair
 * reaches is light grey. */
void cli_pairs_colour_regions(const cli_pair *pairs, size_t count,
                              const cli_shape *b, unsigned char *region_rgb);
/* Over the meshes drawn with view[0] (A) and view[1] (B): the pairs'
 * lines, the markers of the features no pair ends at, and a dot in the
 * pair's colour at both ends of every line; verified pairs solid, the
 * others faint. radius: a verified end's, in pixels. Sets each pair's
 * ends and their visibility. */
void cli_pairs_draw(cli_image *im, cli_pair *pairs, size_t count,
                    const cli_shape shape[2], const cli_view view[2],
                    double radius);

/* ---- PNG (cli_png.c) ----------------------------------------------------- */
/* 1 when the tool was built with libspng. */
int cli_png_supported(void);
/* Writes im as an 8-bit RGB PNG, atomically. 0, or 1 after
 * "phks: path: reason" ("built without PNG support" without libspng). */
int cli_png_write(const char *path, const cli_image *im);

/* ---- the contact sheet (cli_sheet.c) -------------------------------------- */
/* The contact sheet of `db query --png`: the query (mesh_path, a mesh or a
 * .sig, with its signature query) and its hits, each tile a picture of the
 * mesh the entry's name points to, or a placeholder, labelled with the name
 * and score. 0, or 1 after a message. */
int cli_sheet_write(const char *png_path, phks_db *db, const char *mesh_path,
                    const phks_signature *query, const phks_hit *hits,
                    size_t count);

#endif
