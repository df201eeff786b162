/*
 * options.c - the paper's parameters as defaults, and the validation every
 * long-running entry point applies before touching a mesh.
 */
#include "core/core.h"

#include <stddef.h>

#include <math.h>
#include <string.h>

static const double paper_scales[] = {5,   20,  40,  60,  100, 150, 200, 300,
                                      400, 500, 600, 700, 800, 900, 1000};

phks_status phks_options_init(phks_options *options)
{
    if (!options)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_options_init: options is NULL");
    memset(options, 0, sizeof *options);
    options->version = PHKS_OPTIONS_VERSION;
    options->eigen_count = 300;
    options->tau = 0.0002;
    options->cutoff = 3.5;
    options->feature_count = 15;
    options->scale_count = sizeof paper_scales / sizeof paper_scales[0];
    memcpy(options->scales, paper_scales, sizeof paper_scales);
    options->feature_scale = 5;
    /* Departures from the paper, measured in docs/retrieval.md: the
     * random-walk operator evens out the jump rate that halves at a
     * boundary, feature points two kernel widths from a boundary are not
     * the cut's artefacts, and HKS times the area within the kernel's
     * width does not double where a scan lost the back of a thin part. */
    options->operator_kind = PHKS_OPERATOR_RANDOM_WALK;
    options->boundary_margin = 2;
    options->hks_scaling = PHKS_HKS_SCALING_LOCAL_AREA;
    options->box = PHKS_BOX_PRINCIPAL;
    options->solver = PHKS_SOLVER_AUTO;
    options->threads = 0;
    options->tolerance = 1e-10;
    options->simplify_above = 25000;
    options->simplify_target = 10000;
    /* Points inside long triangles: a face meshed as two triangles then
     * looks as it does meshed finely. With spin images proposing it
     * gains on complete and partial queries alike and on catalogues of
     * CAD parts (docs/retrieval.md, "Spin images with the triangle
     * quadrature"); a mesh without a long triangle gets the vertices'
     * numbers. A small coarse mesh pays for it, its points bounded by its
     * area and not its vertices (a cube of 12 triangles gets 8,234,
     * docs/benchmarks.md), so every binding lets its caller ask for the
     * vertices (PostgreSQL's phks_signature_from_mesh too). */
    options->quadrature = PHKS_QUADRATURE_TRIANGLES;
    /* Points judged alone mistake a partial scan for any shape with a
     * few similar points; their layout along the surface tells them
     * apart (docs/retrieval.md). */
    options->matching = PHKS_MATCHING_VERIFIED;
    /* Heat at the larger scales sums over the whole shape, so a cut
     * changes every feature vector; spin images of the surface near each
     * point do not see a cut away from it (docs/method.md section 15). */
    options->local_descriptor = PHKS_LOCAL_DESCRIPTOR_SPIN;
    return PHKS_OK;
}

static bool positive_finite(double x)
{
    return isfinite(x) && x > 0;
}

phks_status phks__options_resolve(const phks_options *user, phks_options *out)
{
    if (!user)
        return phks_options_init(out);
    if (user->version != PHKS_OPTIONS_VERSION)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: version %u is not %d; fill options with "
                         "phks_options_init() first",
                         user->version, PHKS_OPTIONS_VERSION);
    *out = *user;
    if (out->eigen_count < 1 || out->eigen_count > 100000)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: eigen_count %u outside 1..100000",
                         out->eigen_count);
    if (!positive_finite(out->tau) || out->tau > 1)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: tau %g outside (0, 1]", out->tau);
    /* Below 1 the kernel is cut where it still carries most of its weight;
     * above 8 the dropped weight is under e^-64 and only costs time. */
    if (!(out->cutoff >= 1 && out->cutoff <= 8))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: cutoff %g outside [1, 8]", out->cutoff);
    if (out->feature_count < 1 || out->feature_count > 100000)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: feature_count %u outside 1..100000",
                         out->feature_count);
    if (out->scale_count < 1 || out->scale_count > PHKS_MAX_SCALES)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: scale_count %u outside 1..%d",
                         out->scale_count, PHKS_MAX_SCALES);
    for (uint32_t i = 0; i < out->scale_count; i++)
        if (!positive_finite(out->scales[i]))
            return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                             "options: scales[%u] = %g is not a positive "
                             "number", i, out->scales[i]);
    if (!positive_finite(out->feature_scale))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: feature_scale %g is not a positive number",
                         out->feature_scale);
    if (out->operator_kind != PHKS_OPERATOR_LITERAL &&
        out->operator_kind != PHKS_OPERATOR_RANDOM_WALK)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: unknown operator_kind %d",
                         (int)out->operator_kind);
    if (out->box != PHKS_BOX_PRINCIPAL && out->box != PHKS_BOX_AXIS_ALIGNED)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: unknown box %d", (int)out->box);
    if (out->solver < PHKS_SOLVER_AUTO || out->solver > PHKS_SOLVER_DENSE)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: unknown solver %d", (int)out->solver);
    if (!(out->tolerance >= 1e-15 && out->tolerance <= 1e-2))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: tolerance %g outside [1e-15, 1e-2]",
                         out->tolerance);
    if (!(out->boundary_margin >= 0 && out->boundary_margin <= 100))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: boundary_margin %g outside [0, 100]",
                         out->boundary_margin);
    if (out->hks_scaling != PHKS_HKS_SCALING_NONE &&
        out->hks_scaling != PHKS_HKS_SCALING_MEAN &&
        out->hks_scaling != PHKS_HKS_SCALING_LOCAL_AREA)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: unknown hks_scaling %d",
                         (int)out->hks_scaling);
    if (out->quadrature != PHKS_QUADRATURE_VERTICES &&
        out->quadrature != PHKS_QUADRATURE_TRIANGLES)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: unknown quadrature %d",
                         (int)out->quadrature);
    if (out->matching != PHKS_MATCHING_NEAREST &&
        out->matching != PHKS_MATCHING_VERIFIED)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: unknown matching %d", (int)out->matching);
    /* Checked even with NEAREST, which ignores it: kept as given, a bad
     * value would otherwise surface only when matching changes. */
    if (out->local_descriptor != PHKS_LOCAL_DESCRIPTOR_HEAT &&
        out->local_descriptor != PHKS_LOCAL_DESCRIPTOR_SPIN)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: unknown local_descriptor %d",
                         (int)out->local_descriptor);
    /* Checked with NEAREST too, for the same reason. */
    if (out->global_descriptor != PHKS_GLOBAL_DESCRIPTOR_NONE &&
        out->global_descriptor != PHKS_GLOBAL_DESCRIPTOR_D2)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: unknown global_descriptor %d",
                         (int)out->global_descriptor);
    if (out->threads > 1024)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: threads %u above 1024", out->threads);
    /* HKS-simp: fewer than 16 samples cannot carry a spectrum worth the
     * name; beyond 10^8 the samples' own solve is out of reach. Checked
     * even when simplify_above is 0 (never), so a bad value never waits
     * for a large mesh to surface. */
    if (out->simplify_target < 16 || out->simplify_target > 100000000)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "options: simplify_target %u outside 16..100000000",
                         out->simplify_target);
    return PHKS_OK;
}

phks_status phks__progress(const phks_options *opt, phks_stage stage,
                          double fraction)
{
    if (!opt->progress)
        return PHKS_OK;
    if (fraction > 1)
        fraction = 1;
    if (opt->progress(opt->progress_user, stage, fraction) != 0)
        return phks__fail(PHKS_ERROR_CANCELLED,
                         "cancelled by the progress callback");
    return PHKS_OK;
}

phks_status phks__span_report(phks__span s, double fraction)
{
    if (!s.opt)
        return PHKS_OK;
    return phks__progress(s.opt, s.stage, s.done + s.span * fraction);
}

phks__span phks__span_part(phks__span s, double from, double to)
{
    phks__span part = {s.opt, s.stage, s.done + s.span * from,
                       s.span * (to - from)};
    return part;
}
