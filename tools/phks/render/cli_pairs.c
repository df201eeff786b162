/*
 * cli_pairs.c - the pairs of a match in `phks render A B`: which of
 * phks_match's rows are drawn, the colour each takes (its A feature's
 * region), B's regions coloured after the pairs that end in them, and the
 * lines with a dot at both ends. A picture should say what the library
 * says: a line ends in a dot even where B's point is one of its samples,
 * verified pairs are solid and the others faint, and a colour on B means
 * a pair brought it there from A.
 */
#include "render/cli_pictures.h"

#include <math.h>
#include <string.h>

static const unsigned char white[3] = {255, 255, 255};
/* B's regions no pair reaches: a light grey, apart from every palette
 * colour. */
static const unsigned char unreached_rgb[3] = {215, 215, 215};
/* The rim of a faint (unverified) pair's dots. */
static const unsigned char faint_rim_rgb[3] = {110, 110, 110};

static void region_colour_at(const cli_shape *s, uint32_t point,
                             unsigned char rgb[3])
{
    uint32_t v = phks_signature_feature_vertex(s->sig, point);
    cli_region_colour(s->vertex_region[v], rgb);
}

size_t cli_pairs_pick(const phks_correspondence *c, size_t count,
                      cli_pairs_shown shown, const cli_shape *a,
                      cli_pair *out)
{
    size_t n = 0;
    int least = shown == CLI_PAIRS_ALL ? 0 : 1;
    if (shown == CLI_PAIRS_NONE)
        return 0;
    /* Verified pairs first, so that they are drawn over the faint. */
    for (int verified = 1; verified >= least; verified--)
        for (size_t i = 0; i < count; i++) {
            if (!c[i].from_a || (int)c[i].verified != verified)
                continue;
            cli_pair *p = &out[n++];
            memset(p, 0, sizeof *p);
            p->feature_a = c[i].feature_a;
            p->point_b = c[i].feature_b;
            p->verified = verified;
            p->distance = c[i].distance;
            region_colour_at(a, p->feature_a, p->rgb);
        }
    return n;
}

/* Whether pair p says more than pair q about where B's region is on A;
 * at says whether each ends at the region's maximum. */
static int better(const cli_pair *p, int p_at, const cli_pair *q, int q_at)
{
    if (p_at != q_at)
        return p_at;
    if (p->verified != q->verified)
        return p->verified;
    if (p->distance != q->distance)
        return p->distance < q->distance;
    return p->feature_a < q->feature_a;
}

void cli_pairs_colour_regions(const cli_pair *pairs, size_t count,
                              const cli_shape *b, unsigned char *region_rgb)
{
    for (size_t r = 0; r < b->regions; r++) {
        const cli_pair *best = NULL;
        int best_at = 0;
        for (size_t i = 0; i < count; i++) {
            uint32_t v = phks_signature_feature_vertex(b->sig,
                                                       pairs[i].point_b);
            int at = v == b->peak[r];
            if (b->vertex_region[v] == r &&
                (!best || better(&pairs[i], at, best, best_at))) {
                best = &pairs[i];
                best_at = at;
            }
        }
        memcpy(region_rgb + 3 * r, best ? best->rgb : unreached_rgb, 3);
    }
}

/* A pair's colour as drawn: faint pairs halfway to white. */
static void drawn_colour(const cli_pair *p, unsigned char rgb[3])
{
    for (int c = 0; c < 3; c++)
        rgb[c] = p->verified ? p->rgb[c]
                             : (unsigned char)((p->rgb[c] + 255 + 1) / 2);
}

/* A dot of rgb, radius r, in a rim of rim_rgb and a white halo; where the
 * surface hides the point, a ring of rgb in the rim, white inside: hollow,
 * as the markers of hidden features are. */
static void end_dot(cli_image *im, double x, double y, int visible, double r,
                    const unsigned char rgb[3], const unsigned char rim_rgb[3])
{
    double rim = fmax(1.5, r / 4);
    cli_draw_disc(im, x, y, r + rim, rim_rgb);
    cli_draw_disc(im, x, y, r, rgb);
    if (visible)
        cli_draw_ring(im, x, y, r + 2 * rim, rim, white);
    else
        cli_draw_disc(im, x, y, r * 0.4, white);
}

static void line(cli_image *im, const cli_pair *p, double radius)
{
    unsigned char rgb[3];
    drawn_colour(p, rgb);
    if (p->verified) {
        double width = fmax(2, radius / 2);
        cli_draw_line(im, p->ax, p->ay, p->bx, p->by,
                      width + 2 * fmax(1, radius / 8), white);
        cli_draw_line(im, p->ax, p->ay, p->bx, p->by, width, rgb);
    } else {
        cli_draw_line(im, p->ax, p->ay, p->bx, p->by, fmax(1, radius / 4), rgb);
    }
}

static void ends(cli_image *im, const cli_pair *p, double radius)
{
    unsigned char rgb[3];
    const unsigned char *rim = p->verified ? cli_marker_rgb : faint_rim_rgb;
    double r = p->verified ? radius : 0.7 * radius;
    drawn_colour(p, rgb);
    end_dot(im, p->ax, p->ay, p->a_visible, r, rgb, rim);
    end_dot(im, p->bx, p->by, p->b_visible, r, rgb, rim);
}

/* Whether some pair ends at feature i of side s. */
static int paired(const cli_pair *pairs, size_t count, int s, size_t i)
{
    for (size_t k = 0; k < count; k++)
        if ((s == 0 ? pairs[k].feature_a : pairs[k].point_b) == i)
            return 1;
    return 0;
}

void cli_pairs_draw(cli_image *im, cli_pair *pairs, size_t count,
                    const cli_shape shape[2], const cli_view view[2],
                    double radius)
{
    for (size_t k = 0; k < count; k++) {
        double pa[3], pb[3];
        cli_pair *p = &pairs[k];
        phks_signature_feature_position(shape[0].sig, p->feature_a, pa);
        phks_signature_feature_position(shape[1].sig, p->point_b, pb);
        p->a_visible = cli_view_project(&view[0], pa, &p->ax, &p->ay);
        p->b_visible = cli_view_project(&view[1], pb, &p->bx, &p->by);
    }
    /* Backwards: the faint pairs come last in pairs and go under. */
    for (size_t k = count; k-- > 0;)
        line(im, &pairs[k], radius);
    for (int s = 0; s < 2; s++)
        for (size_t i = 0; i < phks_signature_feature_count(shape[s].sig);
             i++) {
            double p[3];
            if (paired(pairs, count, s, i))
                continue;
            phks_signature_feature_position(shape[s].sig, i, p);
            cli_draw_marker(im, &view[s], p, 0.6 * radius);
        }
    for (size_t k = count; k-- > 0;)
        ends(im, &pairs[k], radius);
}
