/* version.c - the run-time version, so a program can tell the header it
 * was built with from the library it runs with. */
#include "core/core.h"

#define PHKS_STR2(x) #x
#define PHKS_STR(x) PHKS_STR2(x)

unsigned phks_version_number(void)
{
    return PHKS_VERSION_NUMBER;
}

const char *phks_version_string(void)
{
    return PHKS_STR(PHKS_VERSION_MAJOR) "." PHKS_STR(PHKS_VERSION_MINOR) "."
        PHKS_STR(PHKS_VERSION_PATCH);
}
