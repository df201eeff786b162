/*
 * install_smoke.c - a program that sees only the installed libphks.
 *
 * tests/test_install.sh builds it against a staged installation, once with
 * nothing but `cc install_smoke.c $(pkg-config --cflags --libs phks)` and
 * once through CMake's find_package(phks), then runs it. It checks that
 * the installed header and the installed shared library belong together
 * and that the basic calls work. Prints what fails; exit status 0 if all
 * passed.
 */
#include <phks.h>

#include <stdio.h>
#include <string.h>

static int failures;

#define CHECK(cond)                                                        \
    do {                                                                   \
        if (!(cond)) {                                                     \
            fprintf(stderr, "install_smoke.c:%d: check failed: %s\n",      \
                    __LINE__, #cond);                                      \
            failures++;                                                    \
        }                                                                  \
    } while (0)

int main(void)
{
    /* Header and library are the same version. */
    CHECK(phks_version_number() == PHKS_VERSION_NUMBER);
    char expected[32];
    snprintf(expected, sizeof expected, "%d.%d.%d", PHKS_VERSION_MAJOR,
             PHKS_VERSION_MINOR, PHKS_VERSION_PATCH);
    CHECK(phks_version_string() != NULL &&
          strcmp(phks_version_string(), expected) == 0);

    /* A tetrahedron, counter-clockwise seen from outside. */
    static const double xyz[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    static const uint32_t triangles[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
    phks_mesh *mesh = NULL;
    CHECK(phks_mesh_create(xyz, 4, triangles, 4, &mesh) == PHKS_OK);
    CHECK(mesh != NULL);
    CHECK(phks_mesh_vertex_count(mesh) == 4);
    CHECK(phks_mesh_triangle_count(mesh) == 4);
    phks_mesh_free(mesh);
    phks_mesh_free(NULL);

    /* A failure: no output handle, a status with a string. */
    mesh = (phks_mesh *)&failures;
    CHECK(phks_mesh_create(NULL, 4, triangles, 4, &mesh) ==
          PHKS_ERROR_INVALID_ARGUMENT);
    CHECK(mesh == NULL);
    CHECK(phks_last_error_message() != NULL);

    const char *ok = phks_status_string(PHKS_OK);
    const char *oom = phks_status_string(PHKS_ERROR_OUT_OF_MEMORY);
    const char *unknown = phks_status_string((phks_status)9999);
    CHECK(ok != NULL && ok[0] != '\0');
    CHECK(oom != NULL && oom[0] != '\0' && strcmp(ok, oom) != 0);
    CHECK(unknown != NULL && strcmp(unknown, "unknown status") == 0);

    if (failures == 0)
        printf("install smoke: libphks %s OK\n", phks_version_string());
    return failures == 0 ? 0 : 1;
}
