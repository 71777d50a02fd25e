#!/usr/bin/env bash
# Soak the random tests: run the suites with GRM_TEST_SEED = FROM..TO (other
# inputs for the same properties; grm-testkit). Each failing seed's log is
# kept under target/soak/; a failure prints its input, which then becomes a
# fixed test. Usage: scripts/soak.sh [FROM [TO [cargo test args...]]]
# (default 1 10, all the workspace's suites; e.g. `scripts/soak.sh 1 50 -p grm-gpu`).
set -euo pipefail
cd "$(dirname "$0")/.."
from=${1:-1}
to=${2:-10}
shift $(( $# < 2 ? $# : 2 ))
args=("$@")
if [ ${#args[@]} -eq 0 ]; then args=(--workspace); fi
mkdir -p target/soak
failed=()
for n in $(seq "$from" "$to"); do
    log=target/soak/seed$n.log
    if GRM_TEST_SEED=$n cargo test -q "${args[@]}" >"$log" 2>&1; then
        echo "seed $n: ok"
        rm -f "$log"
    else
        echo "seed $n: FAILED (see $log)"
        failed+=("$n")
    fi
done
if [ ${#failed[@]} -gt 0 ]; then
    echo "failing seeds: ${failed[*]}"
    exit 1
fi
echo "seeds $from..$to: all passed"
