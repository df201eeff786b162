#!/bin/sh
# test_install.sh SOURCE_ROOT BUILD_ROOT
#
# Installs the build into a scratch DESTDIR, then builds and runs
# tests/install_smoke.c against the installed files only:
#   1. with `cc install_smoke.c $(pkg-config --cflags --libs phks)`,
#   2. with CMake: find_package(phks CONFIG REQUIRED) and phks::phks;
# and runs the installed `phks --version` without LD_LIBRARY_PATH (its
# RPATH, $ORIGIN/../LIBDIR, finds the library from any prefix).
# Exit status: 0 passed, 1 failed, 77 skipped (a tool is missing).
set -eu

if [ $# -ne 2 ]; then
    echo "usage: $0 SOURCE_ROOT BUILD_ROOT" >&2
    exit 1
fi
src=$1
build=$2
cc=${CC:-cc}
smoke=$src/tests/install_smoke.c

for tool in meson ninja python3 pkg-config "$cc"; do
    if ! command -v "$tool" >/dev/null 2>&1; then
        echo "SKIP: $tool not found"
        exit 77
    fi
done

tmp=$(mktemp -d "${TMPDIR:-/tmp}/phks-install.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
trap 'exit 1' HUP INT TERM
stage=$tmp/stage

fail() {
    echo "FAIL: $*" >&2
    exit 1
}

# Prints a log file, then fails.
fail_log() {
    cat "$1" >&2
    shift
    fail "$@"
}

# --- install -------------------------------------------------------------
# `meson test` builds only what tests depend on; build here the installed
# files that are still missing (none after a full build), and only those,
# so that meson install can run with --no-rebuild.
meson introspect "$build" --installed >"$tmp/installed.json" ||
    fail "meson introspect --installed"
python3 - "$build" "$tmp/installed.json" >"$tmp/missing" <<'PY' ||
import json, os, sys
build = os.path.realpath(sys.argv[1])
with open(sys.argv[2]) as f:
    for path in json.load(f):
        # Relative names are the symlinks install makes (libphks.so).
        if not os.path.isabs(path) or os.path.exists(path):
            continue
        path = os.path.relpath(os.path.realpath(path), build)
        if not path.startswith('..'):
            print(path)
PY
    fail "reading meson introspect --installed"
if [ -s "$tmp/missing" ]; then
    echo "building the installed files not built yet:" $(cat "$tmp/missing")
    # shellcheck disable=SC2046 # one target per line, no spaces
    ninja -C "$build" $(cat "$tmp/missing") >"$tmp/ninja.log" 2>&1 ||
        fail_log "$tmp/ninja.log" "building the installed targets"
fi
meson install -C "$build" --destdir "$stage" --no-rebuild --quiet \
    >"$tmp/install.log" 2>&1 || fail_log "$tmp/install.log" "meson install"

pc=$(find "$stage" -name phks.pc -path '*/pkgconfig/*' | head -n 1)
[ -n "$pc" ] || fail "phks.pc was not installed"
prefix=$(sed -n 's/^prefix=//p' "$pc")
version=$(sed -n 's/^Version: *//p' "$pc")
abi=$(sed -n 's/^#define PHKS_ABI_VERSION \([0-9][0-9]*\).*/\1/p' \
      "$src/include/phks.h")
so=$(find "$stage" -name "libphks.so.$abi" | head -n 1)
[ -n "$so" ] || fail "libphks.so.$abi was not installed"
libdir=$(dirname "$so")
echo "installed: prefix $prefix, version $version, library $libdir"

# Runs a smoke binary with the staged library; checks it is the one used.
run_smoke() {
    if command -v ldd >/dev/null 2>&1; then
        used=$(LD_LIBRARY_PATH=$libdir ldd "$1" | grep 'libphks\.so' || true)
        case $used in
            *"$stage"*) ;;
            *) fail "$1 does not load the staged libphks: $used" ;;
        esac
    fi
    LD_LIBRARY_PATH=$libdir "$1" || fail "$1 failed"
}

# --- the tool: starts from the staged prefix through its RPATH ---------------
tool=$(find "$stage" -name phks -type f -path '*/bin/*' | head -n 1)
[ -n "$tool" ] || fail "the phks tool was not installed"
if command -v ldd >/dev/null 2>&1; then
    used=$(env -u LD_LIBRARY_PATH ldd "$tool" | grep 'libphks\.so' || true)
    case $used in
        *"$stage"*) ;;
        *) fail "$tool does not find the staged libphks by itself: $used" ;;
    esac
fi
out=$(env -u LD_LIBRARY_PATH "$tool" --version) ||
    fail "$tool --version without LD_LIBRARY_PATH"
case $out in
    *"libphks $version"*) echo "tool: $out" ;;
    *) fail "$tool --version printed: $out" ;;
esac

# --- the Python extension, where built: its RUNPATH names the installed
# library's folder (the prefix's, not the stage's) ---------------------------
extension=$(find "$stage" -name '_phks*.so' | head -n 1)
if [ -n "$extension" ] && command -v readelf >/dev/null 2>&1; then
    runpath=$(readelf -d "$extension" | sed -n 's/.*(RUNPATH).*\[\(.*\)\]/\1/p')
    case ":$runpath:" in
        *":${libdir#"$stage"}:"*) echo "python extension: RUNPATH $runpath" ;;
        *) fail "$extension: RUNPATH '$runpath' lacks ${libdir#"$stage"}" ;;
    esac
fi

# --- pkg-config ----------------------------------------------------------
# pkgconf puts PKG_CONFIG_SYSROOT_DIR before the -I and -L paths; keep the
# system paths too, in case the prefix is /usr.
flags=$(PKG_CONFIG_PATH=$(dirname "$pc") PKG_CONFIG_SYSROOT_DIR=$stage \
        PKG_CONFIG_ALLOW_SYSTEM_CFLAGS=1 PKG_CONFIG_ALLOW_SYSTEM_LIBS=1 \
        pkg-config --cflags --libs phks) || fail "pkg-config --cflags --libs phks"
echo "pkg-config: $flags"
case $flags in
    *"-I$stage"*"-L$stage"*) ;;
    *) fail "pkg-config flags do not point into the staged install" ;;
esac
# shellcheck disable=SC2086 # flags are meant to be split
"$cc" "$smoke" $flags -o "$tmp/smoke_pkgconfig" >"$tmp/cc.log" 2>&1 ||
    fail_log "$tmp/cc.log" "compiling install_smoke.c with pkg-config flags"
run_smoke "$tmp/smoke_pkgconfig"

# --- CMake ---------------------------------------------------------------
if ! command -v cmake >/dev/null 2>&1; then
    echo "cmake not found: CMake part skipped"
    exit 0
fi
config=$(find "$stage" -name phksConfig.cmake | head -n 1)
[ -n "$config" ] || fail "phksConfig.cmake was not installed"
mkdir "$tmp/cmake"
cp "$smoke" "$tmp/cmake/install_smoke.c"
cat >"$tmp/cmake/CMakeLists.txt" <<CMAKE
cmake_minimum_required(VERSION 3.16)
project(phks_install_smoke C)

# A version newer than the installed one is refused.
find_package(phks 999 CONFIG QUIET)
if(phks_FOUND)
  message(FATAL_ERROR "find_package(phks 999) accepted \${phks_VERSION}")
endif()

find_package(phks $version CONFIG REQUIRED)
if(NOT phks_VERSION STREQUAL "$version")
  message(FATAL_ERROR "phks_VERSION is \${phks_VERSION}, not $version")
endif()
get_target_property(location phks::phks IMPORTED_LOCATION)
get_target_property(include phks::phks INTERFACE_INCLUDE_DIRECTORIES)
foreach(path "\${phks_DIR}" "\${location}" "\${include}")
  string(FIND "\${path}" "$stage/" at)
  if(NOT at EQUAL 0)
    message(FATAL_ERROR "\${path} is not in the staged install")
  endif()
endforeach()

add_executable(install_smoke install_smoke.c)
target_link_libraries(install_smoke PRIVATE phks::phks)
CMAKE
cmake -S "$tmp/cmake" -B "$tmp/cmake/build" -DCMAKE_PREFIX_PATH="$stage$prefix" \
    -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF >"$tmp/cmake.log" 2>&1 ||
    fail_log "$tmp/cmake.log" "cmake configure with find_package(phks)"
cmake --build "$tmp/cmake/build" >"$tmp/cmake-build.log" 2>&1 ||
    fail_log "$tmp/cmake-build.log" "cmake --build"
run_smoke "$tmp/cmake/build/install_smoke"
echo "PASS"
