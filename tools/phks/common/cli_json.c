/*
 * cli_json.c - JSON output of the `phks` tool (--json): strings, numbers
 * that read back exactly, and the options that shape signatures.
 */
#include "common/cli_common.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void cli_json_string(const char *s)
{
    const unsigned char *p = (const unsigned char *)s;
    putchar('"');
    while (*p) {
        size_t len = *p < 0x80 ? 1 : (*p >> 5) == 6 ? 2 : (*p >> 4) == 14 ? 3
                   : (*p >> 3) == 30 ? 4 : 0;
        size_t ok = len;
        for (size_t i = 1; i < len; i++)
            if ((p[i] & 0xc0) != 0x80)
                ok = 0;
        if (*p == '"' || *p == '\\')
            printf("\\%c", *p);
        else if (*p < 0x20)
            printf("\\u%04x", *p);
        else if (ok)
            fwrite(p, 1, len, stdout);
        else
            fputs("\\ufffd", stdout);
        p += ok ? ok : 1;
    }
    putchar('"');
}

void cli_json_number(double x)
{
    char buf[32];
    if (!isfinite(x)) {
        fputs("null", stdout);
        return;
    }
    for (int digits = 15; digits <= 17; digits++) {
        snprintf(buf, sizeof buf, "%.*g", digits, x);
        if (strtod(buf, NULL) == x)
            break;
    }
    fputs(buf, stdout);
}

void cli_json_vec(const double *v, size_t n)
{
    putchar('[');
    for (size_t i = 0; i < n; i++) {
        if (i)
            fputs(", ", stdout);
        cli_json_number(v[i]);
    }
    putchar(']');
}

void cli_json_options(const phks_options *o)
{
    printf("{\"operator\": \"%s\", \"box\": \"%s\", \"tau\": ",
           cli_value_name("operator", o->operator_kind),
           cli_value_name("box", o->box));
    cli_json_number(o->tau);
    fputs(", \"cutoff\": ", stdout);
    cli_json_number(o->cutoff);
    printf(", \"eigen_count\": %u, \"feature_count\": %u, "
           "\"feature_scale\": ", o->eigen_count, o->feature_count);
    cli_json_number(o->feature_scale);
    fputs(", \"scales\": ", stdout);
    cli_json_vec(o->scales, o->scale_count <= PHKS_MAX_SCALES
                                ? o->scale_count : PHKS_MAX_SCALES);
    fputs(", \"boundary_margin\": ", stdout);
    cli_json_number(o->boundary_margin);
    printf(", \"hks_scaling\": \"%s\", \"quadrature\": \"%s\", "
           "\"matching\": \"%s\", \"local_descriptor\": \"%s\", "
           "\"global_descriptor\": \"%s\", "
           "\"simplify_above\": %u, \"simplify_target\": %u}",
           cli_value_name("hks-scaling", o->hks_scaling),
           cli_value_name("quadrature", o->quadrature),
           cli_value_name("matching", o->matching),
           cli_value_name("local-descriptor", o->local_descriptor),
           cli_value_name("global-descriptor", o->global_descriptor),
           o->simplify_above, o->simplify_target);
}
