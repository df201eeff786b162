/* version.c - the run-time version, so a program can tell the header it
 * was built with from the library it runs with. */
#include "core/core.h"

#define PHKS__STR2(x) #x
#define PHKS__STR(x) PHKS__STR2(x)

unsigned phks_version_number(void)
{
    return PHKS_VERSION_NUMBER;
}

const char *phks_version_string(void)
{
    return PHKS__STR(PHKS_VERSION_MAJOR) "." PHKS__STR(PHKS_VERSION_MINOR) "."
        PHKS__STR(PHKS_VERSION_PATCH);
}
