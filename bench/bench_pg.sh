#!/bin/sh
# bench_pg.sh [BUILD_DIR] [-n N | --million] [--queries Q]
# phks_db_query's top 10 in SQL (a shortlist of 100 by sig <#> q,
# re-ranked by sig <~> q: docs/postgres.md) over N synthetic signatures
# (100000; --million: 1000000) on one throwaway PostgreSQL server and on
# three shards behind a postgres_fdw coordinator, all on
# this machine (docs/scale.md). Run as root after building (the extension
# is copied into the server's folders, as tests/test_postgres.py does).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
build=$here/../build
case "${1:-}" in -*|'') ;; *) build=$1; shift ;; esac
args=
while [ $# -gt 0 ]; do
    case "$1" in
        --million) args="$args -n 1000000" ;;
        *) args="$args $1" ;;
    esac
    shift
done
# shellcheck disable=SC2086
exec python3 "$here/bench_pg.py" "$build" $args
