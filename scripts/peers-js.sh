#!/usr/bin/env bash
# grm's one-shot derivation against the npm `lindenmayer` library 1.5.4 in
# string mode (JavaScript), interleaved (scripts/peers-js.mjs). Installs the
# library from the npm registry into target/peers-js once. Not part of the
# tests: a benchmark, docs/benchmarks.md records its figures.
#   ./scripts/peers-js.sh [ROUNDS [BASE_GRMC]]   (BASE_GRMC: an older grmc, run in the same rounds)
# The Rust peers (symbios, lindenmayer-system): cargo bench -p grm-derive --bench peers
set -euo pipefail
cd "$(dirname "$0")/.."
dir=target/peers-js
if [ ! -f "$dir/node_modules/lindenmayer/package.json" ]; then
    mkdir -p "$dir"
    (cd "$dir" && npm init -y >/dev/null && npm install --no-audit --no-fund lindenmayer@1.5.4)
fi
# The lean spawner: the process alone, without node's cost of starting one.
if command -v cc >/dev/null; then
    cc -O2 -o "$dir/spawn-time" scripts/spawn-time.c
else
    echo "peers-js: no C compiler (cc): the process figure is node's spawnSync's" >&2
    rm -f "$dir/spawn-time"
fi
cargo build --release -p grmc --locked
node scripts/peers-js.mjs "${CARGO_TARGET_DIR:-target}/release/grmc" "${1:-15}" "$dir" ${2:+"$2"}
