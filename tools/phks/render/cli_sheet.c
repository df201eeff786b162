/*
 * cli_sheet.c - the contact sheet of `phks db query DB MESH --png OUT.png`:
 * the query and its hits in tiles of 240 x 240 pixels, four to a row, best
 * first. A tile shows the mesh its name points to (a database stores names,
 * not meshes: a name that is the path of a readable mesh file, as `db add`
 * stores it, relative to the current folder) with the feature points of its
 * signature, or a placeholder; under it the name and the score.
 */
#include "render/cli_pictures.h"
#include "common/cli_common.h"
#include "assimp_reader.h"

#include <stdlib.h>
#include <string.h>

/* Labels: two lines of text 8 pixels to a capital, 13 apart. */
enum { TILE = 240, COLUMNS = 4, TEXT = 8, LINE = 13, LABEL = 2 * LINE + 6 };

static const unsigned char ink[3] = {30, 30, 30};
static const unsigned char frame[3] = {170, 170, 170};

/* The mesh at path drawn in the tile's picture area with sig's features,
 * all faces in base; 0, or -1 when path is no mesh (or memory ran out). */
static int draw_entry(cli_image *im, int x, int y, const char *path,
                      const phks_signature *sig, const unsigned char base[3])
{
    phks_mesh *mesh;
    char err[1024];
    if (cli_is_blob(path))
        return -1;
    if (assimp_reader_handles(path)
            ? assimp_reader_load(path, cli_object, &mesh, NULL, 0, err,
                              sizeof err) != PHKS_OK
            : phks_mesh_load(path, &mesh) != PHKS_OK)
        return -1;
    size_t m = phks_mesh_triangle_count(mesh);
    unsigned char *rgb = malloc(3 * m);
    cli_view view;
    int rc = -1;
    if (rgb) {
        for (size_t t = 0; t < m; t++)
            memcpy(rgb + 3 * t, base, 3);
        rc = cli_draw_mesh(im, x + 1, y + 1, TILE - 2, TILE - LABEL - 1, mesh,
                           rgb, NULL, &view);
    }
    if (rc == 0) {
        for (size_t i = 0; sig && i < phks_signature_feature_count(sig); i++) {
            double p[3];
            phks_signature_feature_position(sig, i, p);
            cli_draw_marker(im, &view, p, 3);
        }
        cli_view_free(&view);
    }
    free(rgb);
    phks_mesh_free(mesh);
    return rc;
}

static int placeholder(cli_image *im, int x, int y)
{
    static const unsigned char fill[3] = {235, 235, 235};
    static const unsigned char grey[3] = {140, 140, 140};
    int h = TILE - LABEL - 1;
    cli_fill_rect(im, x + 1, y + 1, TILE - 2, h, fill);
    const char *text = "no mesh";
    return cli_draw_text(im, x + (TILE - cli_text_width(text, 2 * TEXT)) / 2,
                         y + (h + 2 * TEXT) / 2.0, text, 2 * TEXT, grey);
}

/* Tile index: the mesh at path, or a placeholder, and two lines of
 * label. 0, or -1 when out of memory. */
static int tile(cli_image *im, int index, const char *name,
                const char *second, const char *path,
                const phks_signature *sig, const unsigned char base[3])
{
    int x = index % COLUMNS * TILE, y = index / COLUMNS * TILE;
    char buf[64];
    if (draw_entry(im, x, y, path, sig, base) != 0 && placeholder(im, x, y))
        return -1;
    cli_draw_frame(im, x, y, TILE, TILE, frame);
    double baseline = y + TILE - LABEL + 3 + TEXT;
    if (cli_draw_text(im, x + 5, baseline,
                      cli_text_fit(buf, sizeof buf, name, TILE - 10, TEXT),
                      TEXT, ink) != 0)
        return -1;
    return cli_draw_text(im, x + 5, baseline + LINE,
                         cli_text_fit(buf, sizeof buf, second, TILE - 10,
                                      TEXT),
                         TEXT, ink);
}

int cli_sheet_write(const char *png_path, phks_db *db, const char *mesh_path,
                    const phks_signature *query, const phks_hit *hits,
                    size_t count)
{
    static const unsigned char query_rgb[3] = {161, 202, 241};
    static const unsigned char hit_rgb[3] = {215, 215, 210};
    if (!cli_png_supported())
        return cli_png_write(png_path, NULL);
    size_t tiles = count + 1;
    int columns = tiles < COLUMNS ? (int)tiles : COLUMNS;
    int rows = (int)((tiles + COLUMNS - 1) / COLUMNS);
    cli_image im;
    if (cli_image_init(&im, columns * TILE, rows * TILE) != 0)
        return cli_error(png_path, "out of memory");
    int drawn = tile(&im, 0, mesh_path, "query", mesh_path, query, query_rgb);
    for (size_t i = 0; drawn == 0 && i < count; i++) {
        char second[PHKS_DB_TEXT_MAX + 64];
        phks_signature *sig = NULL;
        if (phks_db_get(db, hits[i].id, &sig, NULL, 0, NULL, 0) != PHKS_OK)
            sig = NULL;
        snprintf(second, sizeof second, "#%zu  score %.4g  %s", i + 1,
                 hits[i].score, hits[i].label);
        drawn = tile(&im, (int)i + 1, hits[i].name, second, hits[i].name, sig,
                     hit_rgb);
        phks_signature_free(sig);
    }
    int rc = drawn == 0 ? cli_png_write(png_path, &im)
                        : cli_error(png_path, "out of memory");
    if (rc == 0)
        fprintf(stderr, "wrote %s (%dx%d, %zu tiles)\n", png_path,
                im.width, im.height, tiles);
    cli_image_free(&im);
    return rc;
}
