/*
 * cli_font.c - the stroke font of `phks` pictures: every printable ASCII
 * character as polylines on a grid, drawn with the line rasteriser
 * (cli_draw_line) at any size, so that a caption stays legible from a
 * 240-pixel tile to a 1800 x 1200 figure. A bitmap font can only grow by
 * whole pixels into blocks; strokes scale smoothly and are anti-aliased
 * here by drawing them at 3 x 3 samples per pixel.
 *
 * The grid: x from 0 to the glyph's width, y upwards from the baseline
 * (0): lower-case letters reach 6, capitals, digits and ascenders 9,
 * descenders -3, brackets 10 and -2. A glyph is written as its width and
 * its strokes: points "x,y" joined by spaces into a polyline, polylines
 * parted by ';'; a polyline of one point is a dot. Characters outside
 * ASCII 32..126 are drawn as '?'.
 */
#include "render/cli_pictures.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct glyph {
    int width;            /* grid units                          */
    const char *strokes;  /* "x,y x,y;x,y": polylines, see above */
} glyph;

/* Grid units: a capital's height, the space between glyphs, the stroke's
 * width, and how far any glyph reaches above and below the baseline. */
enum { CAP = 9, TOP = 10, BOTTOM = 3 };
static const double gap = 2.5, stroke = 1.2;

static const glyph glyphs[95] = {
    /* ' ' */ {3, ""},
    /* '!' */ {2, "1,9 1,3;1,0"},
    /* '"' */ {2, "0,9 0,7;2,9 2,7"},
    /* '#' */ {6, "1,0 2,9;4,0 5,9;0,3 6,3;0,6 6,6"},
    /* '$' */ {6, "6,7 4,8 2,8 0,7 0,5 6,3 6,1 4,0 2,0 0,1;3,10 3,-1"},
    /* '%' */ {6, "0,0 6,9;1,9 0,8 1,7 2,8 1,9;5,2 4,1 5,0 6,1 5,2"},
    /* '&' */ {6, "6,0 1,6 1,8 2,9 3,9 4,8 4,7 0,3 0,1 1,0 3,0 6,3"},
    /* ''' */ {0, "0,9 0,7"},
    /* '(' */ {2, "2,10 0,7 0,2 2,-1"},
    /* ')' */ {2, "0,10 2,7 2,2 0,-1"},
    /* '*' */ {6, "3,9 3,3;0,8 6,4;6,8 0,4"},
    /* '+' */ {6, "3,1 3,7;0,4 6,4"},
    /* ',' */ {2, "1,1 1,0 0,-2"},
    /* '-' */ {4, "0,4 4,4"},
    /* '.' */ {2, "1,0"},
    /* '/' */ {5, "0,-1 5,9"},
    /* '0' */ {5, "1,0 4,0 5,2 5,7 4,9 1,9 0,7 0,2 1,0"},
    /* '1' */ {6, "1,7 3,9 3,0;1,0 5,0"},
    /* '2' */ {6, "0,7 2,9 4,9 6,7 6,5 0,0 6,0"},
    /* '3' */ {6, "0,9 6,9 3,5 4,5 6,3 6,2 4,0 2,0 0,2"},
    /* '4' */ {6, "4,0 4,9 0,3 6,3"},
    /* '5' */ {6, "6,9 0,9 0,5 4,5 6,3 6,2 4,0 2,0 0,2"},
    /* '6' */ {6, "5,9 3,9 0,6 0,2 2,0 4,0 6,2 6,3 4,5 2,5 0,3"},
    /* '7' */ {6, "0,9 6,9 2,0"},
    /* '8' */ {6, "2,5 1,6 1,8 2,9 4,9 5,8 5,6 4,5 2,5 0,3 0,2 2,0 4,0 6,2 "
                  "6,3 4,5"},
    /* '9' */ {6, "6,6 4,4 2,4 0,6 0,7 2,9 4,9 6,7 6,3 3,0 1,0"},
    /* ':' */ {2, "1,0;1,5"},
    /* ';' */ {2, "1,5;1,1 1,0 0,-2"},
    /* '<' */ {5, "5,7 0,4 5,1"},
    /* '=' */ {6, "0,3 6,3;0,5 6,5"},
    /* '>' */ {5, "0,7 5,4 0,1"},
    /* '?' */ {5, "0,7 2,9 4,9 5,8 5,6 3,4 3,3;3,0"},
    /* '@' */ {8, "6,3 6,6 5,7 3,7 2,6 2,4 3,3 5,3 6,4;6,3 7,3 8,4 8,7 6,9 "
                  "2,9 0,7 0,2 2,0 6,0"},
    /* 'A' */ {6, "0,0 3,9 6,0;1,3 5,3"},
    /* 'B' */ {6, "0,0 0,9 4,9 5,8 5,6 4,5 0,5;4,5 6,4 6,1 5,0 0,0"},
    /* 'C' */ {6, "6,7 4,9 2,9 0,7 0,2 2,0 4,0 6,2"},
    /* 'D' */ {6, "0,0 0,9 3,9 6,6 6,3 3,0 0,0"},
    /* 'E' */ {6, "6,9 0,9 0,0 6,0;0,5 4,5"},
    /* 'F' */ {6, "6,9 0,9 0,0;0,5 4,5"},
    /* 'G' */ {6, "6,7 4,9 2,9 0,7 0,2 2,0 4,0 6,2 6,4 3,4"},
    /* 'H' */ {6, "0,0 0,9;6,0 6,9;0,5 6,5"},
    /* 'I' */ {4, "0,9 4,9;2,9 2,0;0,0 4,0"},
    /* 'J' */ {6, "6,9 6,2 4,0 2,0 0,2"},
    /* 'K' */ {6, "0,0 0,9;6,9 0,3;2,5 6,0"},
    /* 'L' */ {6, "0,9 0,0 6,0"},
    /* 'M' */ {8, "0,0 0,9 4,3 8,9 8,0"},
    /* 'N' */ {6, "0,0 0,9 6,0 6,9"},
    /* 'O' */ {6, "2,0 4,0 6,2 6,7 4,9 2,9 0,7 0,2 2,0"},
    /* 'P' */ {6, "0,0 0,9 4,9 6,7 6,6 4,4 0,4"},
    /* 'Q' */ {6, "2,0 4,0 6,2 6,7 4,9 2,9 0,7 0,2 2,0;3,3 6,0"},
    /* 'R' */ {6, "0,0 0,9 4,9 6,7 6,6 4,4 0,4;3,4 6,0"},
    /* 'S' */ {6, "6,7 4,9 2,9 0,7 0,6 6,3 6,2 4,0 2,0 0,2"},
    /* 'T' */ {6, "0,9 6,9;3,9 3,0"},
    /* 'U' */ {6, "0,9 0,2 2,0 4,0 6,2 6,9"},
    /* 'V' */ {6, "0,9 3,0 6,9"},
    /* 'W' */ {8, "0,9 2,0 4,6 6,0 8,9"},
    /* 'X' */ {6, "0,0 6,9;0,9 6,0"},
    /* 'Y' */ {6, "0,9 3,5 6,9;3,5 3,0"},
    /* 'Z' */ {6, "0,9 6,9 0,0 6,0"},
    /* '[' */ {2, "2,10 0,10 0,-1 2,-1"},
    /* '\' */ {5, "0,9 5,-1"},
    /* ']' */ {2, "0,10 2,10 2,-1 0,-1"},
    /* '^' */ {4, "0,7 2,9 4,7"},
    /* '_' */ {6, "0,-1 6,-1"},
    /* '`' */ {2, "0,9 2,7"},
    /* 'a' */ {5, "0,5 1,6 4,6 5,5 5,0;5,3 1,3 0,2 0,1 1,0 4,0 5,1"},
    /* 'b' */ {5, "0,9 0,0;0,4 2,6 4,6 5,5 5,1 4,0 2,0 0,2"},
    /* 'c' */ {5, "5,5 4,6 1,6 0,5 0,1 1,0 4,0 5,1"},
    /* 'd' */ {5, "5,9 5,0;5,4 3,6 1,6 0,5 0,1 1,0 3,0 5,2"},
    /* 'e' */ {5, "0,3 5,3 5,5 4,6 1,6 0,5 0,1 1,0 4,0 5,1"},
    /* 'f' */ {4, "4,9 3,9 2,8 2,0;0,6 4,6"},
    /* 'g' */ {5, "5,6 5,-2 4,-3 1,-3 0,-2;5,4 3,6 1,6 0,5 0,1 1,0 3,0 5,2"},
    /* 'h' */ {5, "0,9 0,0;0,4 2,6 4,6 5,5 5,0"},
    /* 'i' */ {0, "0,6 0,0;0,8"},
    /* 'j' */ {2, "2,6 2,-2 1,-3 0,-3;2,8"},
    /* 'k' */ {5, "0,9 0,0;5,6 0,1;2,3 5,0"},
    /* 'l' */ {1, "0,9 0,1 1,0"},
    /* 'm' */ {8, "0,6 0,0;0,5 1,6 3,6 4,5 4,0;4,5 5,6 7,6 8,5 8,0"},
    /* 'n' */ {5, "0,6 0,0;0,4 2,6 4,6 5,5 5,0"},
    /* 'o' */ {5, "1,0 4,0 5,1 5,5 4,6 1,6 0,5 0,1 1,0"},
    /* 'p' */ {5, "0,6 0,-3;0,4 2,6 4,6 5,5 5,1 4,0 2,0 0,2"},
    /* 'q' */ {5, "5,6 5,-3;5,4 3,6 1,6 0,5 0,1 1,0 3,0 5,2"},
    /* 'r' */ {4, "0,6 0,0;0,3 3,6 4,6"},
    /* 's' */ {5, "5,5 4,6 1,6 0,5 0,4 1,3 4,3 5,2 5,1 4,0 1,0 0,1"},
    /* 't' */ {4, "1,9 1,1 2,0 4,0;0,6 4,6"},
    /* 'u' */ {5, "0,6 0,1 1,0 3,0 5,2;5,6 5,0"},
    /* 'v' */ {6, "0,6 3,0 6,6"},
    /* 'w' */ {8, "0,6 2,0 4,4 6,0 8,6"},
    /* 'x' */ {5, "0,6 5,0;0,0 5,6"},
    /* 'y' */ {6, "0,6 3,0;6,6 3,0 1,-3"},
    /* 'z' */ {5, "0,6 5,6 0,0 5,0"},
    /* '{' */ {3, "3,10 2,10 1,9 1,5 0,4 1,3 1,0 2,-1 3,-1"},
    /* '|' */ {0, "0,10 0,-2"},
    /* '}' */ {3, "0,10 1,10 2,9 2,5 3,4 2,3 2,0 1,-1 0,-1"},
    /* '~' */ {6, "0,4 1,5 2,5 4,3 5,3 6,4"},
};

static const glyph *glyph_of(char c)
{
    unsigned char u = (unsigned char)c;
    return &glyphs[(u >= 32 && u < 127 ? u : '?') - 32];
}

/* The stroke's width in pixels: at least one, so that small captions
 * keep their ink. */
static double stroke_width(double size)
{
    double w = stroke * size / CAP;
    return w > 1 ? w : 1;
}

double cli_text_width(const char *text, double size)
{
    double units = 0;
    for (const char *c = text; *c; c++)
        units += glyph_of(*c)->width + (c[1] ? gap : 0);
    return *text ? units * size / CAP + stroke_width(size) : 0;
}

/* Draws one glyph's strokes into mask with its origin (baseline, left) at
 * (x, y) in mask pixels, unit mask pixels per grid unit. */
static void draw_glyph(cli_image *mask, const glyph *g, double x, double y,
                       double unit, double width)
{
    static const unsigned char black[3] = {0, 0, 0};
    const char *s = g->strokes;
    double px = 0, py = 0;
    int first = 1;
    while (*s) {
        char *end;
        long gx = strtol(s, &end, 10), gy = strtol(end + 1, &end, 10);
        double qx = x + gx * unit, qy = y - gy * unit;
        /* A polyline's first point draws itself: a dot when it is alone. */
        cli_draw_line(mask, first ? qx : px, first ? qy : py, qx, qy, width,
                      black);
        px = qx;
        py = qy;
        first = *end == ';';
        s = *end ? end + 1 : end;
    }
}

int cli_draw_text(cli_image *im, double x, double baseline, const char *text,
                  double size, const unsigned char rgb[3])
{
    enum { SS = 3 };  /* samples per pixel along each axis */
    double unit = size / CAP, half = stroke_width(size) / 2;
    int x0 = (int)floor(x - 1), y0 = (int)floor(baseline - TOP * unit - half - 1);
    int w = (int)ceil(cli_text_width(text, size)) + 3;
    int h = (int)ceil((TOP + BOTTOM) * unit + 2 * half) + 3;
    cli_image mask;
    if (!*text)
        return 0;
    if (cli_image_init(&mask, SS * w, SS * h) != 0)
        return -1;
    double gx = SS * (x + half - x0), gy = SS * (baseline - y0);
    for (const char *c = text; *c; c++) {
        const glyph *g = glyph_of(*c);
        draw_glyph(&mask, g, gx, gy, SS * unit, SS * 2 * half);
        gx += SS * unit * (g->width + gap);
    }
    cli_blend_mask(im, x0, y0, &mask, SS, rgb);
    cli_image_free(&mask);
    return 0;
}

char *cli_text_fit(char *buf, size_t size, const char *text, double width,
                   double text_size)
{
    snprintf(buf, size, "%s", text);
    size_t n = strlen(buf);
    while (n > 0 && cli_text_width(buf, text_size) > width) {
        buf[--n] = '\0';
        if (n >= 2)
            memcpy(buf + n - 2, "..", 2);
    }
    return buf;
}
