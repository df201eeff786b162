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
#include "utils/jsonb.h"
#include "utils/numeric.h"

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

/* The text of a JSON value as phks_option_set reads it: a string's
 * characters, a number's digits, an array's elements joined by commas
 * (scales); NULL for what no option takes (true, false, null, objects,
 * nested arrays). */
static char *option_text(const JsonbValue *v)
{
    if (v->type == jbvString)
        return pnstrdup(v->val.string.val, v->val.string.len);
    if (v->type == jbvNumeric)
        return DatumGetCString(
            DirectFunctionCall1(numeric_out, NumericGetDatum(v->val.numeric)));
    if (v->type != jbvBinary || !JsonContainerIsArray(v->val.binary.data))
        return NULL;
    StringInfoData out;
    initStringInfo(&out);
    JsonbIterator *it = JsonbIteratorInit(v->val.binary.data);
    JsonbValue e;
    JsonbIteratorToken tok;
    while ((tok = JsonbIteratorNext(&it, &e, true)) != WJB_DONE) {
        if (tok != WJB_ELEM)
            continue;
        if (e.type != jbvNumeric && e.type != jbvString)
            return NULL;
        appendStringInfo(&out, "%s%s", out.len ? "," : "", option_text(&e));
    }
    return out.data;
}

/* Option `index` of o as its C spelling writes it, palloc'd. */
static char *option_value(const phks_options *o, uint32_t index)
{
    char text[1024];
    if (phks_option_format(o, index, PHKS_SPELLING_C, text, sizeof text) !=
        PHKS_OK)
        text[0] = '\0';
    return pstrdup(text);
}

static void options_error(const char *what, const char *key)
    pg_attribute_noreturn();
static void options_error(const char *what, const char *key)
{
    ereport(ERROR, (errcode(ERRCODE_INVALID_PARAMETER_VALUE),
                    errmsg("phks_signature_from_mesh: options: \"%s\" %s",
                           key, what)));
}

/* The index of the option a member's key sets: an option's name in the C
 * spelling, or NAME_name for an enum option NAME (phks_options(sig)
 * writes its value's name there, beside the number). */
static uint32_t option_of_key(const char *key)
{
    uint32_t index;
    phks_option_type type;
    if (phks_option_find(key, PHKS_SPELLING_C, &index) == PHKS_OK)
        return index;
    size_t n = strlen(key);
    if (n > 5 && strcmp(key + n - 5, "_name") == 0 &&
        phks_option_find(pnstrdup(key, n - 5), PHKS_SPELLING_C, &index) ==
            PHKS_OK &&
        phks_option_type_of(index, &type) == PHKS_OK &&
        type == PHKS_OPTION_ENUM)
        return index;
    options_error("is no option (phks_options(signature) names them)", key);
}

/* Sets *o from a JSON object of options, keyed as phks_options(sig)
 * writes them, so that a table's options can be taken from one of its
 * rows. Members absent keep the defaults. An enum given both as a number
 * and by name must agree (jsonb orders keys shortest first, so the number
 * is set before its name is read). */
static void options_from_jsonb(Jsonb *json, phks_options *o)
{
    if (!JB_ROOT_IS_OBJECT(json))
        ereport(ERROR, (errcode(ERRCODE_INVALID_PARAMETER_VALUE),
                        errmsg("phks_signature_from_mesh: options must be a "
                               "JSON object, as phks_options(signature) "
                               "writes")));
    uint64_t seen = 0; /* options set by earlier members, a bit each */
    JsonbIterator *it = JsonbIteratorInit(&json->root);
    JsonbValue v;
    JsonbIteratorToken tok;
    char *key = NULL;
    while ((tok = JsonbIteratorNext(&it, &v, true)) != WJB_DONE) {
        if (tok == WJB_KEY) {
            key = pnstrdup(v.val.string.val, v.val.string.len);
            continue;
        }
        if (tok != WJB_VALUE)
            continue;
        uint32_t index = option_of_key(key);
        if (strcmp(phks_option_name(index, PHKS_SPELLING_C), "threads") == 0)
            options_error("cannot be set: the backend computes on its own "
                          "thread", key);
        char *text = option_text(&v);
        if (!text)
            options_error("needs a number, a string or an array of numbers",
                          key);
        phks_options trial = *o;
        phks_status st = phks_option_set(&trial, index, text, PHKS_SPELLING_C);
        if (st != PHKS_OK)
            phks_pg_error(st, "phks_signature_from_mesh: options",
                          phks_pg_last_message(st));
        uint64_t bit = index < 64 ? UINT64_C(1) << index : 0;
        if ((seen & bit) &&
            strcmp(option_value(o, index), option_value(&trial, index)) != 0)
            options_error("disagrees with the option's number", key);
        seen |= bit;
        *o = trial;
    }
}

/* The signature of the mesh bytes in argument 0 (format in argument 1),
 * with *options on the backend's own thread, stopped by interrupts. */
static bytea *signature_of(FunctionCallInfo fcinfo, phks_options *options)
{
    bytea *data = PG_GETARG_BYTEA_PP(0);
    phks_format format = format_named(text_to_cstring(PG_GETARG_TEXT_PP(1)));
    phks_mesh *mesh = load_within_limits(data, format);
    options->threads = 1;
    options->progress = progress_interrupts;
    phks_signature *sig = NULL;
    phks_status st = phks_signature_compute(mesh, options, &sig);
    phks_mesh_free(mesh);
    if (st != PHKS_OK) {
        char *msg = phks_pg_last_message(st);
        if (st == PHKS_ERROR_CANCELLED)
            CHECK_FOR_INTERRUPTS();
        phks_pg_error(st, "phks_signature_from_mesh", msg);
    }
    return phks_pg_encode_and_free(sig, "phks_signature_from_mesh");
}

/* phks_signature_from_mesh(mesh bytea, format text): with the library's
 * default options. */
PG_FUNCTION_INFO_V1(phks_pg_from_mesh);
Datum phks_pg_from_mesh(PG_FUNCTION_ARGS)
{
    phks_options options;
    phks_options_init(&options);
    PG_RETURN_BYTEA_P(signature_of(fcinfo, &options));
}

/* phks_signature_from_mesh(mesh bytea, format text, options jsonb): the
 * defaults with the members of options set. */
PG_FUNCTION_INFO_V1(phks_pg_from_mesh_options);
Datum phks_pg_from_mesh_options(PG_FUNCTION_ARGS)
{
    phks_options options;
    phks_options_init(&options);
    options_from_jsonb(PG_GETARG_JSONB_P(2), &options);
    PG_RETURN_BYTEA_P(signature_of(fcinfo, &options));
}
