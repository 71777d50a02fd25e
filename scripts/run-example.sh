#!/usr/bin/env bash
# The main job on a shipped example: build grmc, check every example, and
# grow one into a model file (glTF binary, opens in Blender or any viewer).
#   ./scripts/run-example.sh [EXAMPLE.grm] [OUT.glb|.obj|.ply|.svg]
set -euo pipefail
cd "$(dirname "$0")/.."
example="${1:-examples/ternary_tree.grm}"
out="${2:-$(basename "${example%.grm}").glb}"
cargo build --release -p grmc
./target/release/grmc check examples/*.grm
./target/release/grmc derive "$example" --stats -o "$out"
