#!/bin/sh
# test_layers.sh - the library's layering rule, made mechanical
# (docs/architecture.md): a layer sees only itself and the layers before it.
#
#   test_layers.sh LIBDIR LAYER=ARCHIVE ...   (layers in the pipeline's order)
#
# Two checks:
# - includes: a file in lib/L/ may include "K/..." only for K = L or a layer
#   before L (and the public "phks.h");
# - symbols: every phks symbol an object of layer L leaves undefined is
#   defined by L's archive or an earlier layer's (nm on each archive).
set -eu
libdir=$1
shift
fail=0
seen=""     # the layers so far, L included
defined=$(mktemp)
trap 'rm -f "$defined"' EXIT
for pair in "$@"; do
    layer=${pair%%=*}
    archive=${pair#*=}
    seen="$seen $layer"
    # Includes.
    for f in "$libdir/$layer"/*.c "$libdir/$layer"/*.h; do
        [ -e "$f" ] || continue
        for inc in $(sed -n 's/^[[:space:]]*#[[:space:]]*include[[:space:]]*"\([^"]*\)".*/\1/p' "$f"); do
            [ "$inc" = phks.h ] && continue
            dir=${inc%%/*}
            case " $seen " in
            *" $dir "*) ;;
            *) echo "layers: ${f#"$libdir"/} includes \"$inc\", not a header of $layer or a layer before it"
               fail=1 ;;
            esac
        done
    done
    # Symbols.
    nm -g --defined-only "$archive" 2>/dev/null | awk 'NF == 3 { print $3 }' >>"$defined"
    for sym in $(nm -u "$archive" | awk '$2 ~ /^phks/ { print $2 }' | sort -u); do
        if ! grep -qx "$sym" "$defined"; then
            echo "layers: $layer uses $sym, defined in no layer up to $layer"
            fail=1
        fi
    done
done
[ "$fail" -eq 0 ] && echo "layers: $(echo "$seen" | wc -w) layers, every include and symbol from below"
exit "$fail"
