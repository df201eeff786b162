/*
 * plugin.c - libphks inside a host application (a modeller plug-in, a game
 * tool): meshes come from the host's own memory, not from files. Here the
 * "scene" holds three tori made in code as float vertex and index arrays;
 * the plug-in matches object 1 against a moved, turned and scaled copy
 * (object 2) and against a different shape (object 3), and prints the
 * scores and which feature points correspond. No arguments, no files.
 * (Another tessellation of one shape scores higher, less so the shorter
 * its edges are beside the heat kernel's width, 0.028 of the shape's box.)
 */
#include <phks.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

/* A host's mesh: 3 floats per vertex, 3 indices per triangle. */
typedef struct scene_object {
    float xyz[3 * 48 * 20];
    uint32_t triangles[6 * 48 * 20];
    size_t vertex_count, triangle_count;
} scene_object;

/* A torus of nu x nv vertices whose tube swells in `lobes` places (and,
 * to give every feature point its own heat, a little more on one side),
 * turned a quarter about x when `turn`, scaled by `scale`, moved 5 in x. */
static void make_torus(unsigned nu, unsigned nv, unsigned lobes, int turn,
                       float scale, scene_object *o)
{
    const double pi = 3.14159265358979323846;
    for (unsigned i = 0; i < nu; i++)
        for (unsigned j = 0; j < nv; j++) {
            double u = 2 * pi * i / nu, v = 2 * pi * j / nv;
            double r = 0.3 * (1 + 0.5 * cos(lobes * u) + 0.2 * cos(u + 0.5 * v));
            double x = (1 + r * cos(v)) * cos(u), y = (1 + r * cos(v)) * sin(u);
            double z = r * sin(v);
            float *p = o->xyz + 3 * (i * nv + j);
            p[0] = scale * (float)x + 5;
            p[1] = scale * (float)(turn ? -z : y);
            p[2] = scale * (float)(turn ? y : z);
            uint32_t a = i * nv + j, b = (i + 1) % nu * nv + j;
            uint32_t c = (i + 1) % nu * nv + (j + 1) % nv, d = i * nv + (j + 1) % nv;
            uint32_t *t = o->triangles + 6 * (i * nv + j);
            t[0] = a, t[1] = b, t[2] = c, t[3] = a, t[4] = c, t[5] = d;
        }
    o->vertex_count = (size_t)nu * nv;
    o->triangle_count = 2 * (size_t)nu * nv;
}

static int fail(const char *what, phks_status status)
{
    fprintf(stderr, "plugin: %s: %s (%s)\n", what, phks_status_string(status),
            phks_last_error_message());
    return 1;
}

/* The signature of a scene object; the arrays are copied, not kept. */
static phks_status signature_of(const scene_object *o, phks_signature **sig)
{
    phks_mesh *mesh = NULL;
    phks_status status = phks_mesh_create_f(o->xyz, o->vertex_count,
                                            o->triangles, o->triangle_count,
                                            &mesh);
    if (status == PHKS_OK)
        status = phks_signature_compute(mesh, NULL, sig);
    phks_mesh_free(mesh);
    return status;
}

int main(void)
{
    static scene_object scene[3]; /* static: too large for some stacks */
    make_torus(48, 20, 3, 0, 1.0f, &scene[0]);
    make_torus(48, 20, 3, 1, 2.5f, &scene[1]); /* moved, turned, scaled */
    make_torus(48, 20, 2, 0, 1.0f, &scene[2]); /* two swellings, not three */

    phks_signature *sig[3] = {NULL, NULL, NULL};
    phks_correspondence *pairs = NULL;
    double score12, score13;
    size_t count;
    const char *what = "signature";
    phks_status status = PHKS_OK;
    for (int i = 0; i < 3; i++)
        if ((status = signature_of(&scene[i], &sig[i])) != PHKS_OK)
            goto done;

    what = "score";
    if ((status = phks_score(sig[0], sig[2], &score13)) != PHKS_OK)
        goto done;

    /* The score and its pairs: one per feature of each signature. */
    what = "match";
    count = phks_signature_feature_count(sig[0]) +
            phks_signature_feature_count(sig[1]);
    pairs = malloc(count * sizeof *pairs);
    status = pairs ? phks_match(sig[0], sig[1], pairs, count, &count, &score12)
                   : PHKS_ERROR_OUT_OF_MEMORY;
    if (status != PHKS_OK)
        goto done;

    printf("score 1-2 (same shape, moved): %g\n", score12);
    printf("score 1-3 (other shape):       %g\n", score13);
    printf("feature of object 1 -> nearest feature of object 2:\n");
    what = "feature position";
    for (size_t k = 0; k < count && pairs[k].from_a; k++) {
        double a[3], b[3]; /* in the scene's coordinates */
        if ((status = phks_signature_feature_position(
                 sig[0], pairs[k].feature_a, a)) != PHKS_OK ||
            (status = phks_signature_feature_position(
                 sig[1], pairs[k].feature_b, b)) != PHKS_OK)
            goto done;
        printf("  %2u (%6.2f %6.2f %6.2f) -> %2u (%6.2f %6.2f %6.2f)"
               "  distance %.3g\n", pairs[k].feature_a, a[0], a[1], a[2],
               pairs[k].feature_b, b[0], b[1], b[2], pairs[k].distance);
    }

done: /* one exit: report a failure, free everything (NULL is fine) */
    if (status != PHKS_OK)
        fail(what, status);
    free(pairs);
    for (int i = 0; i < 3; i++)
        phks_signature_free(sig[i]);
    return status == PHKS_OK ? 0 : 1;
}
