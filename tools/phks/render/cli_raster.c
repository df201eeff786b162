/*
 * cli_raster.c - RGB images for `phks` pictures: filled rectangles, discs,
 * rings, thick lines and box-filter downsampling. Pixel (i, j) covers
 * [i, i + 1) x [j, j + 1); shapes cover the pixels whose centre they
 * contain, so every drawing is exact and repeatable.
 */
#include "render/cli_pictures.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

int cli_image_init(cli_image *im, int width, int height)
{
    im->width = width;
    im->height = height;
    im->rgb = malloc((size_t)width * (size_t)height * 3);
    if (!im->rgb)
        return -1;
    memset(im->rgb, 255, (size_t)width * (size_t)height * 3);
    return 0;
}

void cli_image_free(cli_image *im)
{
    free(im->rgb);
    im->rgb = NULL;
}

static void put(cli_image *im, int x, int y, const unsigned char rgb[3])
{
    if (x >= 0 && y >= 0 && x < im->width && y < im->height)
        memcpy(im->rgb + 3 * ((size_t)y * (size_t)im->width + (size_t)x), rgb,
               3);
}

void cli_fill_rect(cli_image *im, int x, int y, int w, int h,
                   const unsigned char rgb[3])
{
    for (int j = y; j < y + h; j++)
        for (int i = x; i < x + w; i++)
            put(im, i, j, rgb);
}

void cli_draw_frame(cli_image *im, int x, int y, int w, int h,
                    const unsigned char rgb[3])
{
    cli_fill_rect(im, x, y, w, 1, rgb);
    cli_fill_rect(im, x, y + h - 1, w, 1, rgb);
    cli_fill_rect(im, x, y, 1, h, rgb);
    cli_fill_rect(im, x + w - 1, y, 1, h, rgb);
}

void cli_draw_ring(cli_image *im, double cx, double cy, double r,
                   double width, const unsigned char rgb[3])
{
    double inner = r - width;
    for (int j = (int)floor(cy - r); j <= (int)ceil(cy + r); j++)
        for (int i = (int)floor(cx - r); i <= (int)ceil(cx + r); i++) {
            double dx = i + 0.5 - cx, dy = j + 0.5 - cy, d2 = dx * dx + dy * dy;
            if (d2 <= r * r && (inner <= 0 || d2 > inner * inner))
                put(im, i, j, rgb);
        }
}

void cli_draw_disc(cli_image *im, double cx, double cy, double r,
                   const unsigned char rgb[3])
{
    cli_draw_ring(im, cx, cy, r, r, rgb);
}

void cli_draw_line(cli_image *im, double x0, double y0, double x1, double y1,
                   double width, const unsigned char rgb[3])
{
    double r = width / 2, dx = x1 - x0, dy = y1 - y0, len2 = dx * dx + dy * dy;
    int i0 = (int)floor(fmin(x0, x1) - r), i1 = (int)ceil(fmax(x0, x1) + r);
    int j0 = (int)floor(fmin(y0, y1) - r), j1 = (int)ceil(fmax(y0, y1) + r);
    for (int j = j0; j <= j1; j++)
        for (int i = i0; i <= i1; i++) {
            double px = i + 0.5 - x0, py = j + 0.5 - y0;
            double s = len2 > 0 ? (px * dx + py * dy) / len2 : 0;
            s = s < 0 ? 0 : s > 1 ? 1 : s;
            double ex = px - s * dx, ey = py - s * dy;
            if (ex * ex + ey * ey <= r * r)
                put(im, i, j, rgb);
        }
}

void cli_downsample(cli_image *dst, int x, int y, const cli_image *src,
                    int factor)
{
    int w = src->width / factor, h = src->height / factor, n = factor * factor;
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++) {
            unsigned sum[3] = {0, 0, 0};
            for (int b = 0; b < factor; b++) {
                const unsigned char *p =
                    src->rgb + 3 * ((size_t)(j * factor + b) * src->width +
                                    (size_t)i * factor);
                for (int a = 0; a < 3 * factor; a++)
                    sum[a % 3] += p[a];
            }
            unsigned char rgb[3];
            for (int c = 0; c < 3; c++)
                rgb[c] = (unsigned char)((sum[c] + n / 2) / n);
            put(dst, x + i, y + j, rgb);
        }
}

void cli_blend_mask(cli_image *dst, int x, int y, const cli_image *mask,
                    int factor, const unsigned char rgb[3])
{
    int w = mask->width / factor, h = mask->height / factor, n = factor * factor;
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++) {
            if (x + i < 0 || y + j < 0 || x + i >= dst->width ||
                y + j >= dst->height)
                continue;
            unsigned dark = 0;
            for (int b = 0; b < factor; b++)
                for (int a = 0; a < factor; a++)
                    dark += 255 - mask->rgb[3 * ((size_t)(j * factor + b) *
                                                     mask->width +
                                                 (size_t)(i * factor + a))];
            unsigned char *p =
                dst->rgb + 3 * ((size_t)(y + j) * dst->width + (size_t)(x + i));
            for (int c = 0; c < 3; c++)
                p[c] = (unsigned char)((p[c] * (255u * n - dark) +
                                        rgb[c] * dark + 255u * n / 2) /
                                       (255u * n));
        }
}
