/*
 * hks.c - the heat kernel signature from a spectrum:
 *     HKS_t(x) = sum_i exp(-t lambda_i) phi_i(x)^2
 * over the computed eigenpairs (a truncation: at small t the omitted terms
 * are not negligible, which is why eigen_count is an option). With HKS-simp
 * phi_i(x) comes from the extension of the samples' eigenvectors
 * (simp_extend.c).
 */
#include "spectrum/simp.h"

double phks__hks_at(const phks_spectrum *spec, double t, size_t v)
{
    if (spec->ext)
        return phks__extend_hks_at(spec, t, v);
    double sum = 0;
    for (size_t i = 0; i < spec->count; i++) {
        double phi = spec->vectors[i * spec->n + v];
        sum += exp(-t * spec->values[i]) * phi * phi;
    }
    return sum;
}

phks_status phks__hks_all(const phks_spectrum *spec, double t,
                         const phks_options *opt, double *out)
{
    if (spec->ext)
        return phks__extend_hks(spec, t, opt,
                               phks__thread_count(opt ? opt : &spec->options),
                               out);
    size_t n = spec->n;
    for (size_t v = 0; v < n; v++)
        out[v] = 0;
    /* Eigenvector-major order walks memory contiguously. */
    for (size_t i = 0; i < spec->count; i++) {
        double decay = exp(-t * spec->values[i]);
        const double *phi = spec->vectors + i * n;
        for (size_t v = 0; v < n; v++)
            out[v] += decay * phi[v] * phi[v];
    }
    return PHKS_OK;
}

phks_status phks_spectrum_hks(const phks_spectrum *spec, double t, double *out)
{
    if (!spec || !out)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_spectrum_hks: NULL argument");
    if (!(t >= 0) || !isfinite(t))
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_spectrum_hks: time %g is not a finite t >= 0", t);
    return phks__hks_all(spec, t, NULL, out);
}
