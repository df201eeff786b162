# cli_helpers.sh - what the shell tests of the command-line programs share
# (test_cli.sh, test_render.sh, test_examples.sh source it after moving to
# their scratch folder). POSIX sh; needs awk.

fail() {
    echo "FAIL: $*" >&2
    echo "--- stdout" >&2; cat out >&2
    echo "--- stderr" >&2; cat err >&2
    exit 1
}
# run CMD...: stdout in ./out, stderr in ./err, exit status in $rc.
run() {
    "$@" >out 2>err
    rc=$?
}
expect_rc() { [ "$rc" = "$1" ] || fail "${2:-}: exit status $rc, expected $1"; }
expect_out() { grep -q -- "$1" out || fail "${2:-}: stdout lacks '$1'"; }
expect_err() { grep -q -- "$1" err || fail "${2:-}: stderr lacks '$1'"; }

# at_vertices PHKS: the path of a script made here that runs PHKS with the
# paper's quadrature at the vertices (--quadrature vertices; a later
# --quadrature on its line wins). The scripts' meshes have a few hundred
# vertices and triangles far longer than the kernel's width: the default
# quadrature's points inside them, thousands per mesh, would make every
# signature cost a PSB model's time (past the sanitizers' timeouts) in
# tests of the tool, not of the quadrature (tests/test_quadrature.c).
at_vertices() {
    printf '#!/bin/sh\nexec "%s" --quadrature vertices "$@"\n' "$1" \
        >phks-at-vertices
    chmod +x phks-at-vertices
    echo "$(pwd)/phks-at-vertices"
}

# blob NU NV A B C BUMP FREQ: a closed bumpy ellipsoid as OFF, 2 + NU (NV-1)
# vertices; the bumps (FREQ of them around the equator) give the heat
# kernel distinct maxima.
blob() {
    awk -v nu="$1" -v nv="$2" -v a="$3" -v b="$4" -v c="$5" -v k="$6" \
        -v f="$7" 'BEGIN {
        pi = atan2(0, -1)
        n = 2 + (nv - 1) * nu
        print "OFF"
        print n, 2 * nu * (nv - 1), 0
        print 0, 0, c
        for (i = 1; i < nv; i++) {
            t = pi * i / nv
            for (j = 0; j < nu; j++) {
                p = 2 * pi * j / nu
                r = 1 + k * (1 + cos(f * p)) * sin(t) ^ 4
                printf "%.9f %.9f %.9f\n", a * r * sin(t) * cos(p),
                    b * r * sin(t) * sin(p), c * cos(t)
            }
        }
        print 0, 0, -c
        for (j = 0; j < nu; j++)
            print 3, 0, 1 + j, 1 + (j + 1) % nu
        for (i = 1; i < nv - 1; i++)
            for (j = 0; j < nu; j++) {
                p = 1 + (i - 1) * nu + j
                q = 1 + (i - 1) * nu + (j + 1) % nu
                print 3, p, p + nu, q + nu
                print 3, p, q + nu, q
            }
        s = n - 1
        base = 1 + (nv - 2) * nu
        for (j = 0; j < nu; j++)
            print 3, s, base + (j + 1) % nu, base + j
    }'
}
