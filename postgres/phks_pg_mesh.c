/*
 * phks_pg_mesh.c - phks_signature_from_mesh: a signature computed in the
 * backend from mesh bytes, within the limits an administrator sets
 * (phks.max_vertices, phks.max_mesh_size), and stopped by a cancel, a
 * statement_timeout or a termination (docs/postgres.md).
 */
#include "phks_pg.h"

#include <limits.h>

#include "miscadmin.h"
#include "utils/builtins.h"
#include "utils/guc.h"

/* A server takes meshes from its clients: a mesh too large for the host
 * must be refused with a message, not end the backend in the kernel's
 * out-of-memory killer. The defaults admit the largest mesh measured
 * (1.6 million vertices, 128 MB of OFF text: about 600 MB and 30 s,
 * docs/benchmarks.md). Settable by superusers (and roles granted SET on
 * them), so that a client cannot raise them. */
static int max_vertices = 2000000;
static int max_mesh_size_kb = 256 * 1024;

void phks_pg_define_mesh_limits(void)
{
    DefineCustomIntVariable(
        "phks.max_vertices",
        "Largest vertex count phks_signature_from_mesh accepts.",
        "Counted as the file lists them (STL: distinct corners); a larger "
        "mesh is refused before it is cleaned or computed.",
        &max_vertices, max_vertices, 1, INT_MAX, PGC_SUSET, 0, NULL, NULL,
        NULL);
    DefineCustomIntVariable(
        "phks.max_mesh_size",
        "Largest mesh data phks_signature_from_mesh accepts, after gzip "
        "inflation.",
        "Inflation stops at the limit; reading holds at most about four "
        "times this much.",
        &max_mesh_size_kb, max_mesh_size_kb, 1, INT_MAX, PGC_SUSET,
        GUC_UNIT_KB, NULL, NULL, NULL);
    MarkGUCPrefixReserved("phks");
}

static phks_format format_named(const char *name)
{
    static const struct {
        const char *name;
        phks_format format;
    } formats[] = {{"auto", PHKS_FORMAT_AUTO}, {"off", PHKS_FORMAT_OFF},
                   {"obj", PHKS_FORMAT_OBJ},   {"ply", PHKS_FORMAT_PLY},
                   {"stl", PHKS_FORMAT_STL}};
    for (size_t i = 0; i < lengthof(formats); i++)
        if (pg_strcasecmp(name, formats[i].name) == 0)
            return formats[i].format;
    ereport(ERROR, (errcode(ERRCODE_INVALID_PARAMETER_VALUE),
                    errmsg("phks_signature_from_mesh: unknown format \"%s\" "
                           "(auto, off, obj, ply or stl)",
                           name)));
    pg_unreachable();
}

/* The mesh of data within the limits, or the error. TOO_LARGE names the
 * settings, since they are the likely cause and the way out. */
static phks_mesh *load_within_limits(bytea *data, phks_format format)
{
    phks_mesh *mesh = NULL;
    phks_status st = phks_mesh_load_memory_limited(
        VARDATA_ANY(data), VARSIZE_ANY_EXHDR(data), format,
        (size_t)max_mesh_size_kb * 1024, (size_t)max_vertices, &mesh);
    if (st == PHKS_ERROR_TOO_LARGE)
        ereport(ERROR,
                (errcode(ERRCODE_PROGRAM_LIMIT_EXCEEDED),
                 errmsg("phks_signature_from_mesh: %s",
                        phks_pg_last_message(st)),
                 errhint("phks.max_vertices is %d and phks.max_mesh_size is "
                         "%d kB; a superuser can raise them.",
                         max_vertices, max_mesh_size_kb)));
    if (st != PHKS_OK)
        phks_pg_error(st, "phks_signature_from_mesh",
                      phks_pg_last_message(st));
    return mesh;
}

/* Asks the library to stop once a cancel, a statement_timeout (which
 * arrives as a cancel) or a termination is pending; CHECK_FOR_INTERRUPTS
 * then raises it, after the handles are freed. */
static int progress_interrupts(void *user, phks_stage stage, double fraction)
{
    (void)user;
    (void)stage;
    (void)fraction;
    return (QueryCancelPending || ProcDiePending) ? 1 : 0;
}

/* phks_signature_from_mesh(mesh bytea, format text): with the library's
 * default options, on the backend's own thread. */
PG_FUNCTION_INFO_V1(phks_pg_from_mesh);
Datum phks_pg_from_mesh(PG_FUNCTION_ARGS)
{
    bytea *data = PG_GETARG_BYTEA_PP(0);
    phks_format format = format_named(text_to_cstring(PG_GETARG_TEXT_PP(1)));
    phks_mesh *mesh = load_within_limits(data, format);
    phks_options options;
    phks_options_init(&options);
    options.threads = 1;
    options.progress = progress_interrupts;
    phks_signature *sig = NULL;
    phks_status st = phks_signature_compute(mesh, &options, &sig);
    phks_mesh_free(mesh);
    if (st != PHKS_OK) {
        char *msg = phks_pg_last_message(st);
        if (st == PHKS_ERROR_CANCELLED)
            CHECK_FOR_INTERRUPTS();
        phks_pg_error(st, "phks_signature_from_mesh", msg);
    }
    PG_RETURN_BYTEA_P(
        phks_pg_encode_and_free(sig, "phks_signature_from_mesh"));
}
