/*
 * alloc.c - the allocator hook. Every allocation of the library goes
 * through phks__malloc and friends so that a host application can route
 * memory to its own heap, and tests can fail the i-th allocation.
 */
#include "core/core.h"

#include <stdlib.h>
#include <string.h>

static void *default_malloc(void *user, size_t size)
{
    (void)user;
    return malloc(size);
}

static void *default_realloc(void *user, void *ptr, size_t size)
{
    (void)user;
    return realloc(ptr, size);
}

static void default_free(void *user, void *ptr)
{
    (void)user;
    free(ptr);
}

static phks_allocator current = {default_malloc, default_realloc, default_free,
                                 NULL};

phks_status phks_set_allocator(const phks_allocator *allocator)
{
    if (!allocator) {
        current = (phks_allocator){default_malloc, default_realloc,
                                   default_free, NULL};
        return PHKS_OK;
    }
    if (!allocator->malloc_fn || !allocator->realloc_fn || !allocator->free_fn)
        return phks__fail(PHKS_ERROR_INVALID_ARGUMENT,
                         "phks_set_allocator: all three functions must be set");
    current = *allocator;
    return PHKS_OK;
}

/* A zero-byte request still returns a distinct pointer, as callers treat
 * NULL as failure. */
void *phks__malloc(size_t size)
{
    return current.malloc_fn(current.user, size ? size : 1);
}

void *phks__realloc(void *ptr, size_t size)
{
    if (!ptr)
        return phks__malloc(size);
    return current.realloc_fn(current.user, ptr, size ? size : 1);
}

void phks__free(void *ptr)
{
    if (ptr)
        current.free_fn(current.user, ptr);
}

void *phks__malloc_array(size_t count, size_t size)
{
    if (size && count > SIZE_MAX / size)
        return NULL;
    return phks__malloc(count * size);
}

void *phks__realloc_array(void *ptr, size_t count, size_t size)
{
    if (size && count > SIZE_MAX / size)
        return NULL;
    return phks__realloc(ptr, count * size);
}

void *phks__calloc(size_t count, size_t size)
{
    void *p = phks__malloc_array(count, size);
    if (p)
        memset(p, 0, count * size);
    return p;
}
