/*
 * cli_regions.c - the colours of HKS regions in `phks` pictures and in
 * `phks segment`'s PLY, and the region of each vertex.
 */
#include "render/cli_pictures.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Kelly's colours of maximum contrast without white, black and grey; then
 * hues spaced by the golden angle: the regions of `phks render` and of
 * `phks segment`'s PLY alike. */
void cli_region_colour(uint32_t r, unsigned char rgb[3])
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

/* The most frequent of the n regions in list; ties go to the lower region,
 * and no region (UINT32_MAX) only to a vertex with no other. */
static uint32_t most_frequent(const uint32_t *list, size_t n)
{
    uint32_t best = UINT32_MAX;
    size_t best_n = 0;
    for (size_t i = 0; i < n; i++) {
        size_t k = 0;
        for (size_t j = 0; j < n; j++)
            k += list[j] == list[i];
        int better = list[i] != UINT32_MAX &&
                     (best == UINT32_MAX || k > best_n ||
                      (k == best_n && list[i] < best));
        if (better || (best == UINT32_MAX && best_n == 0)) {
            best = list[i];
            best_n = k;
        }
    }
    return best;
}

int cli_vertex_regions(const phks_mesh *mesh, const uint32_t *region,
                       uint32_t *vertex_region)
{
    size_t n = phks_mesh_vertex_count(mesh), m = phks_mesh_triangle_count(mesh);
    const uint32_t *tri = phks_mesh_triangles(mesh);
    size_t *start = calloc(n + 1, sizeof *start);
    size_t *fill = calloc(n + 1, sizeof *fill);
    uint32_t *list = malloc((m ? 3 * m : 1) * sizeof *list);
    if (!start || !fill || !list) {
        free(start);
        free(fill);
        free(list);
        return -1;
    }
    for (size_t i = 0; i < 3 * m; i++)
        start[tri[i] + 1]++;
    for (size_t v = 0; v < n; v++)
        start[v + 1] += start[v];
    for (size_t i = 0; i < 3 * m; i++)
        list[start[tri[i]] + fill[tri[i]]++] = region[i / 3];
    for (size_t v = 0; v < n; v++)
        vertex_region[v] = most_frequent(list + start[v], start[v + 1] - start[v]);
    free(fill);
    free(start);
    free(list);
    return 0;
}
