/*
 * cli_pictures.h - pictures of meshes for `phks render` (../cli_render.c)
 * and `phks db query --png` (docs/cli.md): a software rasteriser, a bitmap
 * font and PNG output, all deterministic (the same bytes every run).
 *
 *   cli_raster.c  RGB images: rectangles, discs, lines, downsampling
 *   cli_font.c    the 5x7 bitmap font
 *   cli_view.c    a mesh's view (principal axes, oblique) and its z-buffered,
 *                 Lambert-shaded drawing
 *   cli_png.c     PNG encoding through libspng (optional)
 *   cli_sheet.c   the contact sheet of `db query --png`
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

/* ---- text (cli_font.c) --------------------------------------------------- */
/* Glyphs are 5x7 pixels advancing 6, times scale; text is one line. */
#define CLI_FONT_HEIGHT 7
int cli_text_width(const char *text, int scale);
/* Draws text with its top-left corner at (x, y). */
void cli_draw_text(cli_image *im, int x, int y, const char *text, int scale,
                   const unsigned char rgb[3]);
/* Cuts text (a copy in buf, size bytes) to fit width pixels, ending in
 * ".." when cut; returns buf. */
char *cli_text_fit(char *buf, size_t size, const char *text, int width,
                   int scale);

/* ---- a mesh's view and its drawing (cli_view.c) ------------------------- */
/* The mesh's own frame: centred on its area centroid, its principal axes
 * (of the area-weighted second moments) as x (second largest), y (largest,
 * upwards) and z (smallest, towards the viewer), the surface's third
 * moment along y made not positive and along z not negative, x completing
 * a right-handed frame; then turned 30
 * degrees about the vertical and tilted 20 degrees towards the viewer
 * (looking a little from above), projected orthographically and scaled to
 * fill 90% of the tile. */
typedef struct cli_view {
    double centre[3];
    double rot[3][3];  /* rows: screen right, screen up, towards viewer */
    double scale;      /* pixels per input unit                          */
    double ox, oy;     /* pixel position of the projected centre          */
    int x, y, w, h;    /* the tile, in the image                          */
    int ss;            /* samples per pixel along each axis               */
    double *depth;     /* the tile's z-buffer (ss w by ss h), after drawing */
} cli_view;

/* Draws mesh into the tile (x, y, w, h) of im: each triangle flat-shaded,
 * colour face_rgb[3 t..] (NULL: light grey) times 0.35 + 0.65 |n . l|
 * (two-sided Lambert, l from the upper left front), with a z-buffer,
 * rendered at 3x3 samples per pixel (fewer on tiles above 1.7M pixels)
 * and averaged down. view receives the projection; free
 * it with cli_view_free. 0, or -1 when out of memory. */
int cli_draw_mesh(cli_image *im, int x, int y, int w, int h,
                  const phks_mesh *mesh, const unsigned char *face_rgb,
                  cli_view *view);
void cli_view_free(cli_view *view);
/* The image position of p (input coordinates), and whether it is in front
 * of the drawn surface (1) or hidden behind it (0). */
int cli_view_project(const cli_view *view, const double p[3], double *px,
                     double *py);

/* Feature point markers: a black disc in a white ring when the point is
 * visible, a black ring when the surface hides it. radius in pixels. */
void cli_draw_marker(cli_image *im, const cli_view *view, const double p[3],
                     double radius);
extern const unsigned char cli_marker_rgb[3];  /* 0 0 0 */

/* Region colours: Kelly's contrast colours, then golden-angle hues; grey
 * for UINT32_MAX (no region). The same palette as `phks segment`. */
void cli_region_colour(uint32_t region, unsigned char rgb[3]);

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
