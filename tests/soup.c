/* soup.c - a growable triangle soup and the meshes the tests build in it. */
#include "soup.h"
#include "shapes.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

uint32_t soup_vertex(soup *s, double x, double y, double z)
{
    if (s->nv == s->cap_v) {
        s->cap_v = s->cap_v ? 2 * s->cap_v : 64;
        s->xyz = realloc(s->xyz, s->cap_v * 3 * sizeof *s->xyz);
        REQUIRE(s->xyz);
    }
    s->xyz[3 * s->nv] = x;
    s->xyz[3 * s->nv + 1] = y;
    s->xyz[3 * s->nv + 2] = z;
    return (uint32_t)s->nv++;
}

void soup_triangle(soup *s, uint32_t a, uint32_t b, uint32_t c)
{
    if (s->nt == s->cap_t) {
        s->cap_t = s->cap_t ? 2 * s->cap_t : 64;
        s->tri = realloc(s->tri, s->cap_t * 3 * sizeof *s->tri);
        REQUIRE(s->tri);
    }
    s->tri[3 * s->nt] = a;
    s->tri[3 * s->nt + 1] = b;
    s->tri[3 * s->nt + 2] = c;
    s->nt++;
}

void soup_free(soup *s)
{
    free(s->xyz);
    free(s->tri);
    memset(s, 0, sizeof *s);
}

static phks_mesh *create(const soup *s)
{
    phks_mesh *mesh = NULL;
    phks_status st = phks_mesh_create(s->xyz, s->nv, s->tri, s->nt, &mesh);
    REQUIRE_MSG(st == PHKS_OK, "mesh: %s", phks_last_error_message());
    return mesh;
}

phks_mesh *soup_mesh(const soup *s)
{
    phks_mesh *mesh = create(s);
    REQUIRE(phks_mesh_vertex_count(mesh) == s->nv);
    REQUIRE(phks_mesh_triangle_count(mesh) == s->nt);
    return mesh;
}

phks_mesh *soup_mesh_take(soup *s)
{
    phks_mesh *mesh = create(s);
    REQUIRE(phks_mesh_triangle_count(mesh) == s->nt);
    soup_free(s);
    return mesh;
}

typedef struct {
    uint64_t *keys;
    uint32_t *ids;
    size_t mask;
} edge_map;

/* The midpoint of edge {a, b} pushed to the unit sphere, made on first use. */
static uint32_t midpoint(edge_map *map, soup *s, uint32_t a, uint32_t b)
{
    uint64_t key = (a < b ? (uint64_t)a << 32 | b : (uint64_t)b << 32 | a) + 1;
    size_t i = (size_t)((key * 0x9E3779B97F4A7C15ull) >> 17) & map->mask;
    while (map->keys[i] && map->keys[i] != key)
        i = (i + 1) & map->mask;
    if (map->keys[i])
        return map->ids[i];
    map->keys[i] = key;
    double p[3], len = 0;
    for (int d = 0; d < 3; d++) {
        p[d] = s->xyz[3 * a + d] + s->xyz[3 * b + d];
        len += p[d] * p[d];
    }
    len = sqrt(len);
    return map->ids[i] = soup_vertex(s, p[0] / len, p[1] / len, p[2] / len);
}

void add_icosphere(soup *out, unsigned subdiv, const double center[3],
                   const double axes[3], double noise, uint64_t *rng)
{
    const double g = (1 + sqrt(5.0)) / 2;
    const double base[12][3] = {{-1, g, 0}, {1, g, 0},   {-1, -g, 0}, {1, -g, 0},
                                {0, -1, g}, {0, 1, g},   {0, -1, -g}, {0, 1, -g},
                                {g, 0, -1}, {g, 0, 1},   {-g, 0, -1}, {-g, 0, 1}};
    const uint32_t faces[20][3] = {
        {0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
        {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
        {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
        {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    soup s = {0};
    for (int i = 0; i < 12; i++) {
        double len = sqrt(1 + g * g);
        soup_vertex(&s, base[i][0] / len, base[i][1] / len, base[i][2] / len);
    }
    for (int f = 0; f < 20; f++)
        soup_triangle(&s, faces[f][0], faces[f][1], faces[f][2]);
    for (unsigned level = 0; level < subdiv; level++) {
        size_t size = 1;
        while (size < 4 * 3 * s.nt)
            size *= 2;
        edge_map map = {calloc(size, sizeof(uint64_t)),
                        malloc(size * sizeof(uint32_t)), size - 1};
        REQUIRE(map.keys && map.ids);
        soup next = {0};
        next.xyz = s.xyz;
        next.nv = s.nv;
        next.cap_v = s.cap_v;
        for (size_t f = 0; f < s.nt; f++) {
            uint32_t v[3] = {s.tri[3 * f], s.tri[3 * f + 1], s.tri[3 * f + 2]};
            uint32_t m[3];
            for (int k = 0; k < 3; k++)
                m[k] = midpoint(&map, &next, v[k], v[(k + 1) % 3]);
            soup_triangle(&next, v[0], m[0], m[2]);
            soup_triangle(&next, m[0], v[1], m[1]);
            soup_triangle(&next, m[2], m[1], v[2]);
            soup_triangle(&next, m[0], m[1], m[2]);
        }
        free(map.keys);
        free(map.ids);
        free(s.tri);
        s = next;
    }
    uint32_t first = (uint32_t)out->nv;
    for (size_t v = 0; v < s.nv; v++) {
        double f = 1 + noise * (2 * test_random(rng) - 1);
        soup_vertex(out, center[0] + axes[0] * f * s.xyz[3 * v],
                    center[1] + axes[1] * f * s.xyz[3 * v + 1],
                    center[2] + axes[2] * f * s.xyz[3 * v + 2]);
    }
    for (size_t t = 0; t < s.nt; t++)
        soup_triangle(out, first + s.tri[3 * t], first + s.tri[3 * t + 1],
                      first + s.tri[3 * t + 2]);
    soup_free(&s);
}

void add_box(soup *s, const double size[3], const size_t cells[3])
{
    size_t dim[3] = {cells[0] + 1, cells[1] + 1, cells[2] + 1};
    uint32_t *id = malloc(dim[0] * dim[1] * dim[2] * sizeof *id);
    ck_assert_ptr_nonnull(id);
    for (size_t i = 0; i < dim[0] * dim[1] * dim[2]; i++)
        id[i] = UINT32_MAX;
    for (int d = 0; d < 3; d++)
        for (int side = 0; side < 2; side++) {
            int u = (d + 1) % 3, w = (d + 2) % 3;
            for (size_t i = 0; i < cells[u]; i++)
                for (size_t j = 0; j < cells[w]; j++) {
                    uint32_t corner[4];
                    for (int k = 0; k < 4; k++) {
                        size_t g[3];
                        g[d] = side ? cells[d] : 0;
                        g[u] = i + (k == 1 || k == 2);
                        g[w] = j + (k >= 2);
                        size_t at = (g[2] * dim[1] + g[1]) * dim[0] + g[0];
                        if (id[at] == UINT32_MAX)
                            id[at] = soup_vertex(s,
                                                 size[0] * (double)g[0] / cells[0],
                                                 size[1] * (double)g[1] / cells[1],
                                                 size[2] * (double)g[2] / cells[2]);
                        corner[k] = id[at];
                    }
                    if (side) {
                        soup_triangle(s, corner[0], corner[1], corner[2]);
                        soup_triangle(s, corner[0], corner[2], corner[3]);
                    } else {
                        soup_triangle(s, corner[0], corner[2], corner[1]);
                        soup_triangle(s, corner[0], corner[3], corner[2]);
                    }
                }
        }
    free(id);
}

void add_torus(soup *s, size_t nu, size_t nv, double big, double small,
               double jitter, uint64_t *rng)
{
    uint32_t first = (uint32_t)s->nv;
    for (size_t u = 0; u < nu; u++)
        for (size_t v = 0; v < nv; v++) {
            double a = 2 * PI * (u + jitter * (test_random(rng) - 0.5)) / nu;
            double b = 2 * PI * (v + jitter * (test_random(rng) - 0.5)) / nv;
            soup_vertex(s, (big + small * cos(b)) * cos(a),
                        (big + small * cos(b)) * sin(a), small * sin(b));
        }
    for (size_t u = 0; u < nu; u++)
        for (size_t v = 0; v < nv; v++) {
            uint32_t a = first + (uint32_t)(u * nv + v);
            uint32_t b = first + (uint32_t)(((u + 1) % nu) * nv + v);
            uint32_t c = first + (uint32_t)(((u + 1) % nu) * nv + (v + 1) % nv);
            uint32_t d = first + (uint32_t)(u * nv + (v + 1) % nv);
            soup_triangle(s, a, b, c);
            soup_triangle(s, a, c, d);
        }
}

void crop_z(soup *s, double zmin)
{
    soup out = {0};
    uint32_t *map = malloc(s->nv * sizeof *map);
    REQUIRE(map);
    for (size_t v = 0; v < s->nv; v++)
        map[v] = UINT32_MAX;
    for (size_t t = 0; t < s->nt; t++) {
        const uint32_t *f = s->tri + 3 * t;
        double z = (s->xyz[3 * f[0] + 2] + s->xyz[3 * f[1] + 2] +
                    s->xyz[3 * f[2] + 2]) / 3;
        if (z < zmin)
            continue;
        uint32_t v[3];
        for (int k = 0; k < 3; k++) {
            if (map[f[k]] == UINT32_MAX)
                map[f[k]] = soup_vertex(&out, s->xyz[3 * f[k]], s->xyz[3 * f[k] + 1],
                                        s->xyz[3 * f[k] + 2]);
            v[k] = map[f[k]];
        }
        soup_triangle(&out, v[0], v[1], v[2]);
    }
    free(map);
    soup_free(s);
    *s = out;
}

phks_mesh *creature_mesh(unsigned kind, unsigned pose)
{
    return creature_mesh_moved(kind, pose, NULL, 1, NULL);
}

phks_mesh *creature_mesh_moved(unsigned kind, unsigned pose,
                               const double *rotation, double scale,
                               const double *shift)
{
    double angles[SHAPE_MAX_JOINTS];
    shape_mesh s;
    shape_creature_pose(kind, pose, angles);
    ck_assert_int_eq(shape_creature(kind, angles, 1, &s), 0);
    if (rotation)
        ck_assert_int_eq(shape_transform(&s, rotation, scale, shift), 0);
    phks_mesh *m;
    ck_assert_int_eq(phks_mesh_create(s.xyz, s.vertex_count, s.triangles,
                                      s.triangle_count, &m),
                     PHKS_OK);
    shape_mesh_free(&s);
    return m;
}
