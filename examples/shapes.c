/*
 * shapes.c - closed triangle meshes: icospheres and articulated creatures.
 *
 * A creature is box modelling done in code. Its body is a box whose sides
 * are grids of quads; each limb grows out of one of those quads as a chain
 * of square rings (a tube of quads closed by a cap quad), bent by angles
 * at some of its rings. This coarse quad cage is then smoothed by
 * Catmull-Clark subdivision and each quad split into two triangles.
 * Because the cage is a closed quad mesh, so is every subdivision of it,
 * whatever the pose; the pose moves vertices but never changes the
 * connectivity.
 */
#include "shapes.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define MAX_CELLS 8   /* per body axis */
#define MAX_RINGS 10  /* per limb */
#define MAX_LIMBS 10
#define MAX_BENDS 48

/* ---------------------------------------------------------------------
 * Small vector helpers. Matrices are 3x3 row-major.
 * --------------------------------------------------------------------- */
static void cross(const double a[3], const double b[3], double out[3])
{
    double r[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                   a[0] * b[1] - a[1] * b[0]};
    memcpy(out, r, sizeof r);
}

static void normalize(double v[3])
{
    double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (n > 0) {
        v[0] /= n;
        v[1] /= n;
        v[2] /= n;
    }
}

/* out = a * b */
static void matmul(const double a[9], const double b[9], double out[9])
{
    double r[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            r[3 * i + j] = a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] +
                           a[3 * i + 2] * b[6 + j];
    memcpy(out, r, sizeof r);
}

/* Rotation by |w| radians about the axis w (Rodrigues). */
static void rotation_of_vector(const double w[3], double r[9])
{
    double angle = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    double k[3] = {0, 0, 0};
    if (angle > 0)
        for (int i = 0; i < 3; i++)
            k[i] = w[i] / angle;
    double c = cos(angle), s = sin(angle);
    double kx[9] = {0, -k[2], k[1], k[2], 0, -k[0], -k[1], k[0], 0};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            r[3 * i + j] = (i == j ? c : 0) + (1 - c) * k[i] * k[j] +
                           s * kx[3 * i + j];
}

static uint64_t splitmix64(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static double uniform01(uint64_t *state)
{
    return (double)(splitmix64(state) >> 11) * 0x1.0p-53;
}

/* ---------------------------------------------------------------------
 * Edge table: unordered vertex pairs to dense edge numbers.
 * --------------------------------------------------------------------- */
typedef struct edge_table {
    uint64_t *keys;   /* (low << 32 | high) + 1; 0 marks an empty slot */
    uint32_t *ids;
    size_t mask;
    uint32_t count;
} edge_table;

static int edge_table_init(edge_table *t, size_t max_edges)
{
    size_t size = 16;
    while (size < 2 * max_edges)
        size *= 2;
    t->keys = calloc(size, sizeof *t->keys);
    t->ids = malloc(size * sizeof *t->ids);
    t->mask = size - 1;
    t->count = 0;
    return t->keys && t->ids ? 0 : -2;
}

static void edge_table_free(edge_table *t)
{
    free(t->keys);
    free(t->ids);
}

/* The number of edge {a, b}; *added is set when it is new. */
static uint32_t edge_id(edge_table *t, uint32_t a, uint32_t b, int *added)
{
    uint64_t key = (a < b ? (uint64_t)a << 32 | b : (uint64_t)b << 32 | a) + 1;
    size_t i = (size_t)((key * 0x9E3779B97F4A7C15ull) >> 20) & t->mask;
    while (t->keys[i] != 0 && t->keys[i] != key)
        i = (i + 1) & t->mask;
    *added = t->keys[i] == 0;
    if (*added) {
        t->keys[i] = key;
        t->ids[i] = t->count++;
    }
    return t->ids[i];
}

void shape_mesh_free(shape_mesh *mesh)
{
    if (!mesh)
        return;
    free(mesh->xyz);
    free(mesh->triangles);
    memset(mesh, 0, sizeof *mesh);
}

/* ---------------------------------------------------------------------
 * Icosphere
 * --------------------------------------------------------------------- */
int shape_sphere(unsigned subdivisions, double radius, shape_mesh *out)
{
    if (!out)
        return -1;
    memset(out, 0, sizeof *out);
    if (subdivisions > 9 || !(radius > 0) || !isfinite(radius))
        return -1;
    size_t faces = (size_t)20 << (2 * subdivisions);
    size_t vertices = faces / 2 + 2;
    double *xyz = malloc(3 * vertices * sizeof *xyz);
    uint32_t *tri = malloc(3 * faces * sizeof *tri);
    uint32_t *next = malloc(3 * faces * sizeof *next);
    edge_table edges = {0};
    int status = xyz && tri && next ? edge_table_init(&edges, 3 * faces / 2)
                                    : -2;
    if (status != 0)
        goto done;

    const double g = (1 + sqrt(5.0)) / 2;
    static const signed char corner[12][3] = {
        {-1, 1, 0}, {1, 1, 0}, {-1, -1, 0}, {1, -1, 0},
        {0, -1, 1}, {0, 1, 1}, {0, -1, -1}, {0, 1, -1},
        {1, 0, -1}, {1, 0, 1}, {-1, 0, -1}, {-1, 0, 1}};
    static const unsigned char face[20][3] = {
        {0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11},
        {1, 5, 9}, {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
        {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8}, {3, 8, 9},
        {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
    for (int i = 0; i < 12; i++) {
        /* (+-1, +-g, 0) and its cyclic permutations, g the golden ratio */
        for (int k = 0; k < 3; k++)
            xyz[3 * i + k] = corner[i][k] * (corner[i][(k + 1) % 3] ? 1 : g);
        normalize(&xyz[3 * i]);
    }
    for (int f = 0; f < 20; f++)
        for (int k = 0; k < 3; k++)
            tri[3 * f + k] = face[f][k];

    size_t nv = 12, nf = 20;
    for (unsigned level = 0; level < subdivisions; level++) {
        edges.count = 0;
        memset(edges.keys, 0, (edges.mask + 1) * sizeof *edges.keys);
        for (size_t f = 0; f < nf; f++) {
            uint32_t mid[3];
            for (int k = 0; k < 3; k++) {
                uint32_t a = tri[3 * f + k], b = tri[3 * f + (k + 1) % 3];
                int added;
                mid[k] = (uint32_t)nv + edge_id(&edges, a, b, &added);
                if (added) {
                    for (int c = 0; c < 3; c++)
                        xyz[3 * mid[k] + c] = xyz[3 * a + c] + xyz[3 * b + c];
                    normalize(&xyz[3 * mid[k]]);
                }
            }
            uint32_t v0 = tri[3 * f], v1 = tri[3 * f + 1], v2 = tri[3 * f + 2];
            uint32_t sub[12] = {v0, mid[0], mid[2], v1, mid[1], mid[0],
                                v2, mid[2], mid[1], mid[0], mid[1], mid[2]};
            memcpy(&next[12 * f], sub, sizeof sub);
        }
        nv += edges.count;
        nf *= 4;
        uint32_t *swap = tri;
        tri = next;
        next = swap;
    }
    for (size_t i = 0; i < 3 * nv; i++)
        xyz[i] *= radius;
    out->xyz = xyz;
    out->vertex_count = nv;
    out->triangles = tri;
    out->triangle_count = nf;
    xyz = NULL;
    tri = NULL;
done:
    free(xyz);
    free(tri);
    free(next);
    edge_table_free(&edges);
    return status;
}

/* ---------------------------------------------------------------------
 * Creature definitions
 * ---------------------------------------------------------------------
 * Body sides: side = 2 * axis + (1 on the positive side). The quads of a
 * side form a grid with cell (b, c): b counts along axis (axis + 1) % 3,
 * c along axis (axis + 2) % 3. A limb leaves its cell along the side's
 * outward normal. Bends rotate the rest of the limb; the axis of a bend
 * is given in the body's frame, for the limb still straight, and moves
 * with the limb as earlier bends turn it.
 */
enum { SIDE_NX, SIDE_PX, SIDE_NY, SIDE_PY, SIDE_NZ, SIDE_PZ };

typedef struct limb {
    int side, cell_b, cell_c;
    int rings;                      /* rings beyond the body's face */
    double length;                  /* of the centre line */
    double radius[MAX_RINGS + 1];   /* half width of rings 1..rings */
} limb;

typedef struct bend {
    int limb, ring;      /* spread over the rings ring-2 .. ring+2 */
    double axis[3];      /* unit; the limb's rest frame */
    double rest;         /* angle in the rest pose */
    double lo, hi;       /* range of the joint angle; lo == hi: fixed */
} bend;

typedef struct creature {
    int cells[3];
    double half[3];      /* half extents of the body box */
    limb limbs[MAX_LIMBS];
    int limb_count;
    bend bends[MAX_BENDS];
    int bend_count;
} creature;

/* How the rings ring-2 .. ring+2 share the angle of a bend; the part
 * that would fall on ring 0 (the body) or the tip is left out. */
static const double bend_weight[5] = {1, 2, 3, 2, 1};

static void side_normal(int side, double n[3])
{
    n[0] = n[1] = n[2] = 0;
    n[side / 2] = side % 2 ? 1 : -1;
}

static int add_limb(creature *c, int side, int cell_b, int cell_c, int rings,
                    double length, double r_base, double r_tip)
{
    limb *l = &c->limbs[c->limb_count];
    l->side = side;
    l->cell_b = cell_b;
    l->cell_c = cell_c;
    l->rings = rings;
    l->length = length;
    for (int k = 1; k <= rings; k++)
        l->radius[k] = r_base + (r_tip - r_base) * (k - 1.0) / (rings - 1);
    return c->limb_count++;
}

/* A bend that turns the (straight) limb towards the direction `toward`. */
static void add_bend(creature *c, int limb_index, int ring, double tx,
                     double ty, double tz, double rest, double lo, double hi)
{
    bend *b = &c->bends[c->bend_count++];
    double t[3], toward[3] = {tx, ty, tz};
    side_normal(c->limbs[limb_index].side, t);
    b->limb = limb_index;
    b->ring = ring;
    cross(t, toward, b->axis);
    normalize(b->axis);
    b->rest = rest;
    b->lo = lo;
    b->hi = hi;
}

/* Unit vector in the plane of a side from its centre towards cell (b, c). */
static void lateral(const creature *cr, int side, int cell_b, int cell_c,
                    double out[3])
{
    int axis = side / 2, ab = (axis + 1) % 3, ac = (axis + 2) % 3;
    out[axis] = 0;
    out[ab] = (cell_b + 0.5) / cr->cells[ab] - 0.5;
    out[ac] = (cell_c + 0.5) / cr->cells[ac] - 0.5;
    normalize(out);
}

static void set_body(creature *c, int nx, int ny, int nz, double hx,
                     double hy, double hz)
{
    memset(c, 0, sizeof *c);
    c->cells[0] = nx;
    c->cells[1] = ny;
    c->cells[2] = nz;
    c->half[0] = hx;
    c->half[1] = hy;
    c->half[2] = hz;
}

static void define_quadruped(creature *c)
{
    set_body(c, 5, 3, 1, 0.5, 0.16, 0.14);
    for (int i = 0; i < 4; i++) {      /* legs, under the body */
        int l = add_limb(c, SIDE_NZ, i < 2 ? 0 : 4, i % 2 ? 2 : 0, 7, 0.6,
                         0.05, 0.035);
        add_bend(c, l, 2, 1, 0, 0, 0, -0.3, 0.3);     /* hip */
        add_bend(c, l, 5, 1, 0, 0, 0, -0.35, 0.35);   /* knee */
    }
    int tail = add_limb(c, SIDE_NX, 1, 0, 6, 0.45, 0.035, 0.015);
    add_bend(c, tail, 2, 0, 0, 1, 0.7, 0, 0);
    add_bend(c, tail, 3, 0, 1, 0, 0, -0.45, 0.45);
    int head = add_limb(c, SIDE_PX, 1, 0, 7, 0.6, 0.06, 0.06);
    static const double r[] = {0, 0.06, 0.06, 0.06, 0.075, 0.085, 0.08, 0.05};
    memcpy(c->limbs[head].radius, r, sizeof r);
    add_bend(c, head, 2, 0, 0, 1, 0.8, 0, 0);
    add_bend(c, head, 4, 0, 0, -1, 0.9, 0, 0);
    add_bend(c, head, 2, 0, 1, 0, 0, -0.25, 0.25);   /* look sideways */
    add_bend(c, head, 2, 0, 0, 1, 0, -0.2, 0.2);     /* nod */
}

static void define_humanoid(creature *c)
{
    set_body(c, 3, 1, 3, 0.17, 0.09, 0.26);
    for (int i = 0; i < 2; i++) {
        int leg = add_limb(c, SIDE_NZ, 2 * i, 0, 8, 0.85, 0.06, 0.04);
        add_bend(c, leg, 2, 0, 1, 0, 0, -0.3, 0.35);  /* hip */
        add_bend(c, leg, 5, 0, -1, 0, 0, 0, 0.6);     /* knee */
    }
    for (int i = 0; i < 2; i++) {
        int arm = add_limb(c, i ? SIDE_PX : SIDE_NX, 0, 2, 8, 0.7, 0.045,
                           0.032);
        add_bend(c, arm, 2, 0, 0, -1, 0.9, -0.3, 0.25); /* shoulder */
        add_bend(c, arm, 2, 0, 1, 0, 0, -0.25, 0.25);
        add_bend(c, arm, 5, 0, 1, 0, 0, 0, 0.6);       /* elbow */
    }
    int head = add_limb(c, SIDE_PZ, 1, 0, 8, 0.44, 0.04, 0.04);
    static const double r[] = {0, 0.04, 0.04, 0.04, 0.04, 0.085, 0.1, 0.1, 0.075};
    memcpy(c->limbs[head].radius, r, sizeof r);
    add_bend(c, head, 2, 0, 1, 0, 0, -0.25, 0.25);
    add_bend(c, head, 2, 1, 0, 0, 0, -0.25, 0.25);
}

static void define_octopus(creature *c)
{
    set_body(c, 3, 3, 1, 0.2, 0.2, 0.1);
    int mantle = add_limb(c, SIDE_PZ, 1, 1, 4, 0.45, 0.14, 0.1);
    static const double r[] = {0, 0.14, 0.17, 0.16, 0.1};
    memcpy(c->limbs[mantle].radius, r, sizeof r);
    for (int i = 0; i < 8; i++) {
        int side = i / 2 < 2 ? (i / 2 ? SIDE_PX : SIDE_NX)
                             : (i / 2 == 3 ? SIDE_PY : SIDE_NY);
        int cb = side < SIDE_NY ? (i % 2) * 2 : 0;
        int cc = side < SIDE_NY ? 0 : (i % 2) * 2;
        int l = add_limb(c, side, cb, cc, 8, 0.9, 0.05, 0.012);
        double d[3];
        lateral(c, side, cb, cc, d);
        add_bend(c, l, 2, d[0], d[1], d[2], 0.35, 0, 0);  /* fan out */
        add_bend(c, l, 3, 0, 0, -1, 0.35, 0, 0);          /* hang down */
        add_bend(c, l, 4, 0, 0, -1, 0, -0.5, 0.5);
        add_bend(c, l, 5, d[0], d[1], d[2], 0, -0.3, 0.3);
        add_bend(c, l, 6, 0, 0, -1, 0, -0.6, 0.6);
    }
}

static void define_hand(creature *c)
{
    set_body(c, 4, 1, 3, 0.2, 0.055, 0.22);
    static const double length[4] = {0.45, 0.5, 0.47, 0.37};
    static const double splay[4] = {0.12, 0.04, -0.04, -0.12};
    for (int i = 0; i < 4; i++) {       /* index to little finger */
        int f = add_limb(c, SIDE_PZ, i, 0, 8, length[i], 0.038, 0.028);
        add_bend(c, f, 2, -1, 0, 0, splay[i], 0, 0);
        for (int k = 2; k <= 6; k += 2)
            add_bend(c, f, k, 0, -1, 0, 0, -0.1, 0.3);
    }
    int thumb = add_limb(c, SIDE_NX, 0, 0, 7, 0.36, 0.045, 0.032);
    add_bend(c, thumb, 2, 0, 0, 1, 0.7, 0, 0);
    add_bend(c, thumb, 2, 0, -1, 0, 0.3, 0, 0);
    add_bend(c, thumb, 2, 0, 0, 1, 0, -0.2, 0.2);
    add_bend(c, thumb, 4, 0, -1, 0, 0, 0, 0.4);
}

static void define_plier(creature *c)
{
    set_body(c, 1, 2, 1, 0.07, 0.1, 0.035);
    for (int i = 0; i < 2; i++) {
        double side_y = i ? 1 : -1;
        int jaw = add_limb(c, SIDE_PX, i, 0, 5, 0.32, 0.04, 0.018);
        add_bend(c, jaw, 2, 0, side_y, 0, 0, 0, 0.45);
        int handle = add_limb(c, SIDE_NX, i, 0, 9, 0.95, 0.038, 0.03);
        add_bend(c, handle, 2, 0, side_y, 0, 0.12, 0, 0);
        add_bend(c, handle, 6, 0, -side_y, 0, 0.08, 0, 0);
        add_bend(c, handle, 2, 0, side_y, 0, 0, 0, 0.3);
    }
}

static int define(unsigned kind, creature *c)
{
    static void (*const definer[SHAPE_KIND_COUNT])(creature *) = {
        define_quadruped, define_humanoid, define_octopus, define_hand,
        define_plier};
    if (kind >= SHAPE_KIND_COUNT)
        return -1;
    definer[kind](c);
    return 0;
}

static int joint_count(const creature *c)
{
    int n = 0;
    for (int i = 0; i < c->bend_count; i++)
        n += c->bends[i].lo < c->bends[i].hi;
    return n;
}

static size_t cage_quad_count(const creature *c)
{
    size_t n = 2 * (size_t)(c->cells[0] * c->cells[1] +
                            c->cells[1] * c->cells[2] +
                            c->cells[2] * c->cells[0]);
    for (int i = 0; i < c->limb_count; i++)
        n += 4 * (size_t)c->limbs[i].rings;
    return n;
}

const char *shape_creature_name(unsigned kind)
{
    static const char *const name[SHAPE_KIND_COUNT] = {
        "quadruped", "humanoid", "octopus", "hand", "plier"};
    return kind < SHAPE_KIND_COUNT ? name[kind] : NULL;
}

unsigned shape_creature_joint_count(unsigned kind)
{
    creature c;
    return define(kind, &c) == 0 ? (unsigned)joint_count(&c) : 0;
}

size_t shape_creature_vertex_count(unsigned kind, unsigned resolution)
{
    creature c;
    if (define(kind, &c) != 0 || resolution > SHAPE_MAX_RESOLUTION)
        return 0;
    /* A closed genus-0 quad mesh has quads + 2 vertices. */
    return (cage_quad_count(&c) << (2 * resolution)) + 2;
}

unsigned shape_creature_pose(unsigned kind, unsigned pose_index,
                             double *angles)
{
    creature c;
    if (!angles || define(kind, &c) != 0)
        return 0;
    uint64_t state = (uint64_t)kind << 32 | pose_index;
    splitmix64(&state);
    unsigned n = 0;
    for (int i = 0; i < c.bend_count; i++) {
        const bend *b = &c.bends[i];
        if (b->lo < b->hi) {
            double u = uniform01(&state);
            angles[n++] = pose_index ? b->lo + (b->hi - b->lo) * u : 0;
        }
    }
    return n;
}

/* ---------------------------------------------------------------------
 * The cage: body box plus limbs, posed.
 * --------------------------------------------------------------------- */
typedef struct cage {
    double *xyz;
    uint32_t *quads;
    size_t vertex_count, quad_count;
} cage;

static uint32_t cage_vertex(cage *g, const double p[3])
{
    memcpy(&g->xyz[3 * g->vertex_count], p, 3 * sizeof *p);
    return (uint32_t)g->vertex_count++;
}

static void cage_quad(cage *g, size_t at, uint32_t a, uint32_t b, uint32_t c,
                      uint32_t d)
{
    uint32_t q[4] = {a, b, c, d};
    memcpy(&g->quads[4 * at], q, sizeof q);
}

/* The box surface; face_of[side][b][c] receives the quad of each cell. */
static void build_body(cage *g, const creature *c,
                       size_t face_of[6][MAX_CELLS][MAX_CELLS])
{
    const uint32_t none = UINT32_MAX;
    uint32_t index[MAX_CELLS + 1][MAX_CELLS + 1][MAX_CELLS + 1];
    const int *n = c->cells;
    for (int i = 0; i <= n[0]; i++)
        for (int j = 0; j <= n[1]; j++)
            for (int k = 0; k <= n[2]; k++) {
                int on_surface = i == 0 || i == n[0] || j == 0 || j == n[1] ||
                                 k == 0 || k == n[2];
                int ijk[3] = {i, j, k};
                double p[3];
                for (int a = 0; a < 3; a++)
                    p[a] = c->half[a] * (2.0 * ijk[a] / n[a] - 1);
                index[i][j][k] = on_surface ? cage_vertex(g, p) : none;
            }
    for (int side = 0; side < 6; side++) {
        int axis = side / 2, ab = (axis + 1) % 3, ac = (axis + 2) % 3;
        for (int b = 0; b < n[ab]; b++)
            for (int cc = 0; cc < n[ac]; cc++) {
                uint32_t v[4];
                for (int corner = 0; corner < 4; corner++) {
                    int ijk[3];
                    ijk[axis] = side % 2 ? n[axis] : 0;
                    ijk[ab] = b + (corner == 1 || corner == 2);
                    ijk[ac] = cc + (corner >= 2);
                    v[corner] = index[ijk[0]][ijk[1]][ijk[2]];
                }
                /* (b, c) -> (b+1, c) -> (b+1, c+1) is counter-clockwise
                 * seen from the positive side of the axis. */
                if (side % 2)
                    cage_quad(g, g->quad_count, v[0], v[1], v[2], v[3]);
                else
                    cage_quad(g, g->quad_count, v[3], v[2], v[1], v[0]);
                face_of[side][b][cc] = g->quad_count++;
            }
    }
}

/* Grows limb li out of its body quad, bent by the angles of bends. */
static void build_limb(cage *g, const creature *c, int li,
                       const double *bend_angle, size_t face)
{
    const limb *l = &c->limbs[li];
    uint32_t ring[4];
    memcpy(ring, &g->quads[4 * face], sizeof ring);

    /* The frame (t, u, w) as the columns of a rotation: t the outward
     * normal, u the side's first grid axis. */
    double t[3], u[3] = {0, 0, 0}, w[3], frame[9], centre[3] = {0, 0, 0};
    side_normal(l->side, t);
    u[(l->side / 2 + 1) % 3] = 1;
    cross(t, u, w);
    for (int r = 0; r < 3; r++) {
        frame[3 * r] = t[r];
        frame[3 * r + 1] = u[r];
        frame[3 * r + 2] = w[r];
    }
    for (int k = 0; k < 4; k++)
        for (int r = 0; r < 3; r++)
            centre[r] += g->xyz[3 * ring[k] + r] / 4;
    /* Each corner keeps its quadrant (signs along u and w). */
    double su[4], sw[4];
    for (int k = 0; k < 4; k++) {
        double du = 0, dw = 0;
        for (int r = 0; r < 3; r++) {
            du += (g->xyz[3 * ring[k] + r] - centre[r]) * u[r];
            dw += (g->xyz[3 * ring[k] + r] - centre[r]) * w[r];
        }
        su[k] = du > 0 ? 1 : -1;
        sw[k] = dw > 0 ? 1 : -1;
    }

    /* Turn per ring, as a rotation vector in the limb's local frame. */
    double turn[MAX_RINGS + 1][3] = {{0}};
    for (int i = 0; i < c->bend_count; i++) {
        const bend *b = &c->bends[i];
        if (b->limb != li)
            continue;
        double local[3];
        for (int r = 0; r < 3; r++)
            local[r] = frame[r] * b->axis[0] + frame[3 + r] * b->axis[1] +
                       frame[6 + r] * b->axis[2];
        double sum = 0;
        for (int k = b->ring - 2; k <= b->ring + 2; k++)
            if (k >= 1 && k < l->rings)
                sum += bend_weight[k - b->ring + 2];
        for (int k = b->ring - 2; k <= b->ring + 2; k++)
            if (k >= 1 && k < l->rings)
                for (int r = 0; r < 3; r++)
                    turn[k][r] += bend_weight[k - b->ring + 2] / sum *
                                  bend_angle[i] * local[r];
    }

    double step = l->length / l->rings, p[3];
    memcpy(p, centre, sizeof p);
    for (int k = 1; k <= l->rings; k++) {
        for (int r = 0; r < 3; r++)
            p[r] += step * frame[3 * r];
        /* The ring lies halfway between the directions before and after. */
        double half_turn[3], rot[9], ring_frame[9];
        for (int r = 0; r < 3; r++)
            half_turn[r] = turn[k][r] / 2;
        rotation_of_vector(half_turn, rot);
        matmul(frame, rot, ring_frame);
        uint32_t next[4];
        for (int q = 0; q < 4; q++) {
            double v[3];
            for (int r = 0; r < 3; r++)
                v[r] = p[r] + l->radius[k] * (su[q] * ring_frame[3 * r + 1] +
                                              sw[q] * ring_frame[3 * r + 2]);
            next[q] = cage_vertex(g, v);
        }
        for (int q = 0; q < 4; q++)
            cage_quad(g, g->quad_count++, ring[q], ring[(q + 1) % 4],
                      next[(q + 1) % 4], next[q]);
        memcpy(ring, next, sizeof ring);
        rotation_of_vector(turn[k], rot);
        matmul(frame, rot, frame);
    }
    /* The body quad becomes the cap at the tip. */
    cage_quad(g, face, ring[0], ring[1], ring[2], ring[3]);
}

/* ---------------------------------------------------------------------
 * Catmull-Clark subdivision of a closed quad mesh.
 * New vertices: old vertices, then edge points, then face points. Corner
 * 0 of every new quad is an old vertex and corner 2 a face point.
 * --------------------------------------------------------------------- */
static int subdivide(cage *g)
{
    size_t nv = g->vertex_count, nq = g->quad_count, ne = 2 * nq;
    size_t total = nv + ne + nq;
    double *xyz = calloc(3 * total, sizeof *xyz);
    uint32_t *quads = malloc(16 * nq * sizeof *quads);
    uint32_t *quad_edge = malloc(4 * nq * sizeof *quad_edge);
    uint32_t *valence = calloc(nv, sizeof *valence);
    edge_table edges = {0};
    int status = xyz && quads && quad_edge && valence
                     ? edge_table_init(&edges, ne) : -2;
    if (status != 0)
        goto done;

    double *edge_pt = &xyz[3 * nv], *face_pt = &xyz[3 * (nv + ne)];
    for (size_t f = 0; f < nq; f++) {
        const uint32_t *q = &g->quads[4 * f];
        for (int k = 0; k < 4; k++) {
            for (int r = 0; r < 3; r++)
                face_pt[3 * f + r] += g->xyz[3 * q[k] + r] / 4;
            int added;
            uint32_t e = edge_id(&edges, q[k], q[(k + 1) % 4], &added);
            quad_edge[4 * f + k] = e;
            if (added)   /* each edge gets its end points once */
                for (int r = 0; r < 3; r++)
                    edge_pt[3 * e + r] += (g->xyz[3 * q[k] + r] +
                                           g->xyz[3 * q[(k + 1) % 4] + r]) / 4;
        }
    }
    /* Vertex point (Q + 2R + (n - 3) S) / n with Q the mean of the face
     * points around, R the mean of the edge midpoints: accumulate
     * Q * n + 2 R * n = sum of face points + sum over edges (a + b). */
    for (size_t f = 0; f < nq; f++) {
        const uint32_t *q = &g->quads[4 * f];
        for (int k = 0; k < 4; k++) {
            uint32_t e = quad_edge[4 * f + k];
            for (int r = 0; r < 3; r++)
                edge_pt[3 * e + r] += face_pt[3 * f + r] / 4;
            valence[q[k]]++;
            for (int r = 0; r < 3; r++)
                /* each edge is seen from both of its quads: weight 1/2 */
                xyz[3 * q[k] + r] += face_pt[3 * f + r] +
                    (g->xyz[3 * q[k] + r] + g->xyz[3 * q[(k + 1) % 4] + r]) / 2 +
                    (g->xyz[3 * q[k] + r] + g->xyz[3 * q[(k + 3) % 4] + r]) / 2;
        }
    }
    for (size_t v = 0; v < nv; v++) {
        double n = valence[v];
        for (int r = 0; r < 3; r++)
            xyz[3 * v + r] = xyz[3 * v + r] / (n * n) +
                             (n - 3) * g->xyz[3 * v + r] / n;
    }
    for (size_t f = 0; f < nq; f++) {
        const uint32_t *q = &g->quads[4 * f];
        uint32_t centre = (uint32_t)(nv + ne + f);
        for (int k = 0; k < 4; k++) {
            uint32_t *out = &quads[16 * f + 4 * k];
            out[0] = q[k];
            out[1] = (uint32_t)nv + quad_edge[4 * f + k];
            out[2] = centre;
            out[3] = (uint32_t)nv + quad_edge[4 * f + (k + 3) % 4];
        }
    }
    free(g->xyz);
    free(g->quads);
    g->xyz = xyz;
    g->quads = quads;
    g->vertex_count = total;
    g->quad_count = 4 * nq;
    xyz = NULL;
    quads = NULL;
done:
    free(xyz);
    free(quads);
    free(quad_edge);
    free(valence);
    edge_table_free(&edges);
    return status;
}

int shape_creature(unsigned kind, const double *angles, unsigned resolution,
                   shape_mesh *out)
{
    if (!out)
        return -1;
    memset(out, 0, sizeof *out);
    creature c;
    if (define(kind, &c) != 0 || resolution > SHAPE_MAX_RESOLUTION)
        return -1;

    double bend_angle[MAX_BENDS];
    for (int i = 0, j = 0; i < c.bend_count; i++) {
        const bend *b = &c.bends[i];
        double a = angles && b->lo < b->hi ? angles[j++] : 0;
        if (!isfinite(a))
            return -1;
        bend_angle[i] = b->rest + a;
    }

    size_t quads = cage_quad_count(&c);
    cage g = {malloc(3 * (quads + 2) * sizeof(double)),
              malloc(4 * quads * sizeof(uint32_t)), 0, 0};
    if (!g.xyz || !g.quads) {
        free(g.xyz);
        free(g.quads);
        return -2;
    }
    size_t face_of[6][MAX_CELLS][MAX_CELLS];
    build_body(&g, &c, face_of);
    for (int i = 0; i < c.limb_count; i++) {
        const limb *l = &c.limbs[i];
        build_limb(&g, &c, i, bend_angle, face_of[l->side][l->cell_b][l->cell_c]);
    }
    for (unsigned level = 0; level < resolution; level++)
        if (subdivide(&g) != 0) {
            free(g.xyz);
            free(g.quads);
            return -2;
        }

    /* Split each quad along the diagonal from corner 0 to corner 2. */
    uint32_t *tri = malloc(6 * g.quad_count * sizeof *tri);
    if (!tri) {
        free(g.xyz);
        free(g.quads);
        return -2;
    }
    for (size_t f = 0; f < g.quad_count; f++) {
        const uint32_t *q = &g.quads[4 * f];
        uint32_t two[6] = {q[0], q[1], q[2], q[0], q[2], q[3]};
        memcpy(&tri[6 * f], two, sizeof two);
    }
    free(g.quads);
    out->xyz = g.xyz;
    out->vertex_count = g.vertex_count;
    out->triangles = tri;
    out->triangle_count = 2 * g.quad_count;
    return 0;
}

/* ---------------------------------------------------------------------
 * Transformations
 * --------------------------------------------------------------------- */
int shape_transform(shape_mesh *mesh, const double rotation[9], double scale,
                    const double translation[3])
{
    static const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    static const double zero[3] = {0, 0, 0};
    if (!mesh || scale == 0 || !isfinite(scale))
        return -1;
    const double *r = rotation ? rotation : identity;
    const double *t = translation ? translation : zero;
    for (size_t v = 0; v < mesh->vertex_count; v++) {
        double *p = &mesh->xyz[3 * v], q[3];
        for (int i = 0; i < 3; i++)
            q[i] = scale * (r[3 * i] * p[0] + r[3 * i + 1] * p[1] +
                            r[3 * i + 2] * p[2]) + t[i];
        memcpy(p, q, sizeof q);
    }
    double det = r[0] * (r[4] * r[8] - r[5] * r[7]) -
                 r[1] * (r[3] * r[8] - r[5] * r[6]) +
                 r[2] * (r[3] * r[7] - r[4] * r[6]);
    if (det * scale < 0)
        for (size_t f = 0; f < mesh->triangle_count; f++) {
            uint32_t swap = mesh->triangles[3 * f + 1];
            mesh->triangles[3 * f + 1] = mesh->triangles[3 * f + 2];
            mesh->triangles[3 * f + 2] = swap;
        }
    return 0;
}

void shape_random_rotation(uint64_t seed, double rotation[9])
{
    /* Shoemake: a uniform unit quaternion from three uniform numbers. */
    uint64_t state = seed;
    double u1 = uniform01(&state), u2 = uniform01(&state),
           u3 = uniform01(&state), pi2 = 2 * acos(-1.0);
    double a = sqrt(1 - u1), b = sqrt(u1);
    double w = a * sin(pi2 * u2), x = a * cos(pi2 * u2),
           y = b * sin(pi2 * u3), z = b * cos(pi2 * u3);
    double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),
                   2 * (x * z + w * y),     2 * (x * y + w * z),
                   1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                   2 * (x * z - w * y),     2 * (y * z + w * x),
                   1 - 2 * (x * x + y * y)};
    memcpy(rotation, r, sizeof r);
}
