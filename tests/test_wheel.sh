#!/bin/sh
# test_wheel.sh SOURCE_ROOT
#
# The Python package as Python users install it (pyproject.toml,
# meson-python; docs/python.md), in a fresh virtual environment of
# /usr/bin/python3 that sees Debian's packages:
#   1. `pip wheel --no-build-isolation .` makes a wheel that holds the
#      package alone: phks/__init__.py and the extension, the library
#      linked in (no libphks.so, tool, PostgreSQL module, tests or
#      benchmarks);
#   2. `pip install --no-build-isolation .` installs it, and with no
#      PYTHONPATH or LD_LIBRARY_PATH `import phks` loads the installed
#      package, whose version is the header's and the wheel's;
#   3. docs/python.md's tour runs there (python/tests/test_docs.py).
# Exit status: 0 passed, 1 failed, 77 skipped (no venv or meson-python).
set -eu

if [ $# -ne 1 ]; then
    echo "usage: $0 SOURCE_ROOT" >&2
    exit 1
fi
src=$(cd "$1" && pwd)
python=/usr/bin/python3

for module in venv mesonpy numpy pytest; do
    if ! "$python" -c "import $module" >/dev/null 2>&1; then
        echo "SKIP: $python cannot import $module (Debian: python3-venv" \
             "python3-mesonpy python3-numpy python3-pytest)"
        exit 77
    fi
done

tmp=$(mktemp -d "${TMPDIR:-/tmp}/phks-wheel.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
trap 'exit 1' HUP INT TERM

fail() {
    echo "FAIL: $*" >&2
    exit 1
}

fail_log() {
    cat "$1" >&2
    shift
    fail "$@"
}

# Nothing of the build tree may leak in: only what pip installed counts.
clean_env() {
    env -u PYTHONPATH -u LD_LIBRARY_PATH -u PYTHONHOME "$@"
}

"$python" -m venv --system-site-packages "$tmp/venv" ||
    fail "$python -m venv --system-site-packages"
pip="$tmp/venv/bin/pip"
venv_python="$tmp/venv/bin/python"
cd "$tmp"

# --- 1. the wheel --------------------------------------------------------
clean_env "$pip" wheel --no-build-isolation --no-index --no-deps \
    -w "$tmp/wheels" "$src" >"$tmp/wheel.log" 2>&1 ||
    fail_log "$tmp/wheel.log" "pip wheel"
wheel=$(ls "$tmp"/wheels/phks-*.whl)
"$python" - "$wheel" <<'PY' || fail "the wheel holds other files"
import re, sys, zipfile
names = zipfile.ZipFile(sys.argv[1]).namelist()
print("wheel:", ", ".join(names))
package = [n for n in names if not re.match(r"phks-[^/]*\.dist-info/", n)]
allowed = re.compile(r"(phks-[^/]*\.data/purelib/)?phks/(__init__\.py|"
                     r"_phks\.[^/]*\.so)$")
strays = [n for n in package if not allowed.match(n)]
assert not strays, "not the package's: %s" % strays
assert any(n.endswith("__init__.py") for n in package), "no __init__.py"
assert any(n.endswith(".so") for n in package), "no extension"
PY

# --- 2. pip install . ----------------------------------------------------
clean_env "$pip" install --no-build-isolation --no-index "$src" \
    >"$tmp/install.log" 2>&1 || fail_log "$tmp/install.log" "pip install ."
header_version=$(sed -n 's/^#define PHKS_VERSION_\(MAJOR\|MINOR\|PATCH\) \([0-9]*\).*/\2/p' \
                 "$src/include/phks.h" | paste -sd. -)
clean_env "$venv_python" - "$tmp/venv" "$header_version" <<'PY' ||
import importlib.metadata, os, sys
import phks
venv, header = sys.argv[1], sys.argv[2]
where = os.path.realpath(phks.__file__)
assert where.startswith(os.path.realpath(venv)), "imported from %s" % where
installed = importlib.metadata.version("phks")
assert phks.__version__ == header == installed, (
    "versions: module %s, header %s, package %s"
    % (phks.__version__, header, installed))
print("import phks: %s from %s" % (phks.__version__, where))
PY
    fail "import phks in the virtual environment"
extension=$(ls "$tmp"/venv/lib/python3*/site-packages/phks/_phks*.so)
if command -v readelf >/dev/null 2>&1; then
    if readelf -d "$extension" | grep -q 'libphks\.so'; then
        fail "the extension needs libphks.so: the library is not inside"
    fi
fi

# --- 3. the tour ---------------------------------------------------------
clean_env "$venv_python" -m pytest -q -p no:cacheprovider \
    "$src/python/tests/test_docs.py" >"$tmp/tour.log" 2>&1 ||
    fail_log "$tmp/tour.log" "docs/python.md's tour in the virtual environment"
tail -n 1 "$tmp/tour.log"
echo "pip wheel, pip install . and the tour: passed"
