/*
 * error.c - status strings and the per-thread detail message. One buffer
 * per thread, so a failure in one thread never overwrites the message
 * another thread is about to read.
 */
#include "core/core.h"

#include <stdio.h>
#include <string.h>

#define MESSAGE_SIZE 512

static _Thread_local char message[MESSAGE_SIZE];

const char *phks_status_string(phks_status status)
{
    switch (status) {
    case PHKS_OK: return "success";
    case PHKS_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case PHKS_ERROR_OUT_OF_MEMORY: return "out of memory";
    case PHKS_ERROR_IO: return "input/output error";
    case PHKS_ERROR_UNKNOWN_FORMAT: return "unknown file format";
    case PHKS_ERROR_PARSE: return "malformed file";
    case PHKS_ERROR_TRUNCATED: return "truncated data";
    case PHKS_ERROR_NON_FINITE: return "non-finite number";
    case PHKS_ERROR_INDEX_OUT_OF_RANGE: return "index out of range";
    case PHKS_ERROR_NO_TRIANGLES: return "no triangles";
    case PHKS_ERROR_ZERO_AREA: return "zero area";
    case PHKS_ERROR_TOO_LARGE: return "too large";
    case PHKS_ERROR_CANCELLED: return "cancelled";
    case PHKS_ERROR_NO_CONVERGENCE: return "eigen-solver did not converge";
    case PHKS_ERROR_INCOMPATIBLE: return "incompatible signatures";
    case PHKS_ERROR_CORRUPT: return "corrupt data";
    case PHKS_ERROR_UNSUPPORTED_VERSION: return "unsupported format version";
    case PHKS_ERROR_BUFFER_TOO_SMALL: return "buffer too small";
    case PHKS_ERROR_SOLVER: return "numerical library failure";
    }
    return "unknown status";
}

const char *phks_last_error_message(void)
{
    return message;
}

phks_status phks__fail(phks_status status, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(message, sizeof message, fmt, ap);
    va_end(ap);
    return status;
}

phks_status phks__fail_oom(const char *what)
{
    return phks__fail(PHKS_ERROR_OUT_OF_MEMORY, "out of memory: %s", what);
}

void phks__error_prefix(const char *prefix)
{
    /* Shift the old message right and put "prefix: " in front, cutting the
     * tail when the whole does not fit. */
    size_t plen = strlen(prefix), mlen = strlen(message);
    if (plen + 2 >= sizeof message)
        plen = sizeof message - 3;
    if (plen + 2 + mlen >= sizeof message)
        mlen = sizeof message - 1 - plen - 2;
    memmove(message + plen + 2, message, mlen);
    memcpy(message, prefix, plen);
    message[plen] = ':';
    message[plen + 1] = ' ';
    message[plen + 2 + mlen] = '\0';
}
