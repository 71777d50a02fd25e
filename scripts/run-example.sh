#!/usr/bin/env bash
# The main job on a shipped example: build grmc, check every example, and
# grow one into a model file.
#   ./scripts/run-example.sh [EXAMPLE.grm] [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
example="${1:-examples/ternary_tree.grm}"
cargo build --release -p grmc
./target/release/grmc check examples/*.grm
