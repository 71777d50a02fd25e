#!/usr/bin/env bash
# Two threads against one on the CPU derivation scenes, two `grmc`
# binaries alternately, for a quiet machine (nothing else running: on a
# loaded one the wall-clock 2T/1T column means nothing).
#
#   scripts/bench-threads-quiet.sh OLD_GRMC NEW_GRMC [ROUNDS] [-- EXTRA ARGS]
#
# Runs `grmc bench derive --threads 2 --runs 30 --no-baseline` with OLD,
# then NEW, ROUNDS times (default 3), from the repository root (the
# examples folder), and prints the load average before each call, each
# call's table, and at the end one line per scene and binary with its
# 2T/1T column across the rounds. Extra arguments after `--` go to every
# call (e.g. `-- --scene hilbert3d --scene koch_island`).
set -euo pipefail

if [ $# -lt 2 ]; then
    echo "usage: $0 OLD_GRMC NEW_GRMC [ROUNDS] [-- EXTRA ARGS]" >&2
    exit 2
fi
old=$1
new=$2
shift 2
rounds=3
if [ $# -gt 0 ] && [ "$1" != "--" ]; then
    rounds=$1
    shift
fi
if [ $# -gt 0 ] && [ "$1" = "--" ]; then
    shift
fi
cd "$(dirname "$0")/.."
for b in "$old" "$new"; do
    if [ ! -x "$b" ]; then
        echo "$0: $b is not an executable" >&2
        exit 2
    fi
done

out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for r in $(seq 1 "$rounds"); do
    for which in old new; do
        if [ $which = old ]; then b=$old; else b=$new; fi
        echo "== round $r, $which ($b), load $(cut -d' ' -f1-3 /proc/loadavg)"
        "$b" bench derive --threads 2 --runs 30 --no-baseline "$@" | tee "$out/$which-$r.txt"
    done
done

echo
echo "2T/1T per round (the last column of each call):"
for which in old new; do
    for f in "$out/$which"-*.txt; do
        # Scene rows: a name, then the iteration count.
        awk '$2 ~ /^[0-9]+$/ && NF > 8 { print $1, $NF }' "$f"
    done | awk -v w=$which '
        { v[$1] = v[$1] (v[$1] == "" ? "" : ", ") $2; if (!($1 in seen)) { seen[$1] = 1; order[n++] = $1 } }
        END { for (i = 0; i < n; i++) printf "%-20s %-4s %s\n", order[i], w, v[order[i]] }'
done | sort -s -k1,1
