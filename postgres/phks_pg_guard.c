/*
 * phks_pg_guard.c - the trigger phks_one_option_set(column): a table whose
 * signatures were all made with one option set refuses a row made with
 * another when it is written, naming the option, instead of the next
 * query failing (docs/postgres.md, "One option set per table").
 *
 * The reference is any other row of the table with a signature in that
 * column: every row passed the same check when it was written, so one
 * stands for all. Where there is none yet, two first rows may be written
 * at once: the trigger then takes a transaction lock of its own on the
 * table and looks again, so the second waits for the first to commit and,
 * under READ COMMITTED, sees it.
 */
#include "phks_pg.h"

#include "commands/trigger.h"
#include "executor/spi.h"
#include "utils/builtins.h"
#include "utils/fmgrprotos.h"
#include "utils/lsyscache.h"
#include "utils/rel.h"

/* The first key of the advisory lock a table's first rows take ("PHKS");
 * the second is the table's oid. */
#define GUARD_LOCK_CLASS 0x50484b53

static void guard_misuse(const char *why)
{
    ereport(ERROR, (errcode(ERRCODE_E_R_I_E_TRIGGER_PROTOCOL_VIOLATED),
                    errmsg("phks_one_option_set: %s", why)));
}

/* A copy, in the caller's memory context, of the column's value in one
 * other row of the table, or NULL when there is none. */
static bytea *reference_signature(Relation rel, const char *column,
                                  ItemPointer self)
{
    char *query = psprintf(
        "SELECT %s FROM %s.%s WHERE %s IS NOT NULL AND ctid <> $1 LIMIT 1",
        quote_identifier(column),
        quote_identifier(get_namespace_name(RelationGetNamespace(rel))),
        quote_identifier(RelationGetRelationName(rel)),
        quote_identifier(column));
    Oid types[1] = {TIDOID};
    Datum values[1] = {PointerGetDatum(self)};
    MemoryContext caller = CurrentMemoryContext;
    if (SPI_connect() != SPI_OK_CONNECT)
        guard_misuse("SPI_connect failed");
    /* Not read-only: under READ COMMITTED a new snapshot then shows rows
     * committed while the lock below was awaited. */
    if (SPI_execute_with_args(query, 1, types, values, NULL, false, 1) !=
        SPI_OK_SELECT)
        guard_misuse("the reference row could not be read");
    bytea *copy = NULL;
    if (SPI_processed == 1) {
        bool isnull;
        Datum d = SPI_getbinval(SPI_tuptable->vals[0], SPI_tuptable->tupdesc,
                                1, &isnull);
        MemoryContext spi = MemoryContextSwitchTo(caller);
        copy = isnull ? NULL : DatumGetByteaPCopy(d);
        MemoryContextSwitchTo(spi);
    }
    SPI_finish();
    return copy;
}

/* The options of a stored blob (decoded, then freed). */
static phks_options options_of(bytea *blob, const char *what)
{
    phks_signature *sig = phks_pg_decode(VARDATA_ANY(blob),
                                         VARSIZE_ANY_EXHDR(blob), what);
    phks_options o;
    phks_status st = phks_signature_options(sig, &o);
    phks_signature_free(sig);
    if (st != PHKS_OK)
        phks_pg_error(st, what, phks_pg_last_message(st));
    return o;
}

/* The column's name, after checking the trigger's declaration. */
static const char *guarded_column(FunctionCallInfo fcinfo, int *attnum)
{
    if (!CALLED_AS_TRIGGER(fcinfo))
        guard_misuse("not called as a trigger");
    TriggerData *td = (TriggerData *)fcinfo->context;
    if (!TRIGGER_FIRED_AFTER(td->tg_event) ||
        !TRIGGER_FIRED_FOR_ROW(td->tg_event) ||
        TRIGGER_FIRED_BY_DELETE(td->tg_event))
        guard_misuse("must be an AFTER INSERT OR UPDATE ... FOR EACH ROW "
                     "trigger");
    if (td->tg_trigger->tgnargs != 1)
        guard_misuse("takes one argument, the signature column's name");
    const char *column = td->tg_trigger->tgargs[0];
    TupleDesc desc = RelationGetDescr(td->tg_relation);
    *attnum = SPI_fnumber(desc, column);
    if (*attnum <= 0)
        guard_misuse(psprintf("no column \"%s\"", column));
    char *type = SPI_gettype(desc, *attnum);
    if (!type || strcmp(type, "phks_signature") != 0)
        guard_misuse(psprintf("column \"%s\" is not a phks_signature",
                              column));
    return column;
}

/* The options of the table's other rows, or NULL while it has none. Found
 * once per statement and kept in fn_extra, which lives as long as the
 * statement: every row the statement writes is held to the same options,
 * so a multi-row INSERT reads and decodes one reference, not one a row. */
static const phks_options *table_options(FunctionCallInfo fcinfo,
                                         const char *column, HeapTuple row)
{
    if (fcinfo->flinfo->fn_extra)
        return fcinfo->flinfo->fn_extra;
    Relation rel = ((TriggerData *)fcinfo->context)->tg_relation;
    bytea *reference = reference_signature(rel, column, &row->t_self);
    if (!reference) {
        DirectFunctionCall2(pg_advisory_xact_lock_int4,
                            Int32GetDatum(GUARD_LOCK_CLASS),
                            Int32GetDatum((int32)RelationGetRelid(rel)));
        reference = reference_signature(rel, column, &row->t_self);
    }
    if (!reference)
        return NULL;
    phks_options *o = MemoryContextAlloc(fcinfo->flinfo->fn_mcxt, sizeof *o);
    *o = options_of(reference, "phks_one_option_set");
    fcinfo->flinfo->fn_extra = o;
    return o;
}

PG_FUNCTION_INFO_V1(phks_pg_one_option_set);
Datum phks_pg_one_option_set(PG_FUNCTION_ARGS)
{
    int attnum;
    const char *column = guarded_column(fcinfo, &attnum);
    TriggerData *td = (TriggerData *)fcinfo->context;
    HeapTuple row = TRIGGER_FIRED_BY_UPDATE(td->tg_event) ? td->tg_newtuple
                                                          : td->tg_trigtuple;
    bool isnull;
    Datum d = SPI_getbinval(row, RelationGetDescr(td->tg_relation), attnum,
                            &isnull);
    if (isnull)
        return PointerGetDatum(NULL);
    const phks_options *theirs = table_options(fcinfo, column, row);
    if (!theirs)
        return PointerGetDatum(NULL);
    phks_options mine = options_of(DatumGetByteaPP(d), "phks_one_option_set");
    char detail[256];
    if (phks_options_compare(&mine, theirs, PHKS_SPELLING_C, detail,
                             sizeof detail) != PHKS_OK)
        ereport(ERROR,
                (errcode(ERRCODE_INVALID_PARAMETER_VALUE),
                 errmsg("phks_one_option_set: %s.%s holds signatures made "
                        "with other options: %s",
                        RelationGetRelationName(td->tg_relation), column,
                        detail),
                 errdetail("The new row's value comes first, the table's "
                           "second.")));
    return PointerGetDatum(NULL);
}
