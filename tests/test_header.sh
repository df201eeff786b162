#!/bin/sh
# test_header.sh INCLUDE_DIR CC [CC_ARG...]
#
# The public header on its own, in a small program that uses its types,
# enums and macros and calls a function: compiles without a warning as
# C99 and C11 (-pedantic -Werror) with the build's C compiler, and as
# C++11 with a C++ compiler (g++, clang++ or $CXX), where every function
# must keep C linkage (extern "C": unmangled names in the object file).
# Exit status: 0 passed, 1 failed, 77 skipped (C passed, no C++ compiler).
set -eu
if [ $# -lt 2 ]; then
    echo "usage: $0 INCLUDE_DIR CC [CC_ARG...]" >&2
    exit 1
fi
inc=$1
shift

tmp=$(mktemp -d "${TMPDIR:-/tmp}/phks-header.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
trap 'exit 1' HUP INT TERM

cat >"$tmp/use.c" <<'PROGRAM'
#include <phks.h>
#include <phks.h> /* twice: the include guard */

static int cancel(void *user, phks_stage stage, double fraction)
{
    (void)user;
    return stage == PHKS_STAGE_EIGEN && fraction > 0.5;
}

int main(void)
{
    phks_options options;
    phks_allocator allocator = {0, 0, 0, 0};
    phks_maximum maximum;
    phks_correspondence pair;
    phks_mesh *mesh = 0;
    phks_signature *signature = 0;
    phks_status status = phks_options_init(&options);
    phks_format format = PHKS_FORMAT_AUTO;
    options.progress = cancel;
    options.operator_kind = PHKS_OPERATOR_LITERAL;
    options.box = PHKS_BOX_PRINCIPAL;
    options.solver = PHKS_SOLVER_AUTO;
    (void)allocator;
    (void)maximum;
    (void)pair;
    (void)phks_mesh_load_memory("", 0, format, &mesh);
    phks_mesh_free(mesh);
    phks_signature_free(signature);
    return status == PHKS_OK && phks_version_number() == PHKS_VERSION_NUMBER
               ? (int)PHKS_ABI_VERSION - (int)PHKS_ABI_VERSION
               : (int)sizeof(phks_options) * 0 + 1;
}
PROGRAM

fail=0
for std in c99 c11; do
    if "$@" -std=$std -pedantic -Werror -Wall -Wextra -Wstrict-prototypes \
        -I"$inc" -c "$tmp/use.c" -o "$tmp/use_$std.o" 2>"$tmp/err"; then
        echo "ok: $* -std=$std -pedantic -Werror"
    else
        echo "FAIL: $* -std=$std -pedantic -Werror:"
        cat "$tmp/err"
        fail=1
    fi
done
[ $fail -eq 0 ] || exit 1

cxx=
for c in ${CXX:-} g++ clang++ c++; do
    if command -v "$c" >/dev/null 2>&1; then
        cxx=$c
        break
    fi
done
if [ -z "$cxx" ]; then
    echo "SKIP: C passed; no C++ compiler (g++, clang++ or CXX) to try C++"
    exit 77
fi
if ! "$cxx" -std=c++11 -pedantic -Werror -Wall -Wextra -x c++ -I"$inc" \
    -c "$tmp/use.c" -o "$tmp/use_cxx.o" 2>"$tmp/err"; then
    echo "FAIL: $cxx -std=c++11 -pedantic -Werror:"
    cat "$tmp/err"
    exit 1
fi
echo "ok: $cxx -std=c++11 -pedantic -Werror"
if command -v nm >/dev/null 2>&1; then
    if ! nm -u "$tmp/use_cxx.o" | grep -q ' phks_mesh_load_memory$'; then
        echo "FAIL: C++ does not see phks_mesh_load_memory with C linkage:"
        nm -u "$tmp/use_cxx.o"
        exit 1
    fi
    echo "ok: C linkage from C++"
fi
exit 0
