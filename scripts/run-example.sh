#!/usr/bin/env bash
# The main job on a shipped example: build grmc, check every example, and
# grow one into a model file (glTF binary, opens in Blender or any viewer)
# and, when OUT is not given, a picture of it beside (NAME.png, no viewer
# needed).
#   ./scripts/run-example.sh [EXAMPLE.grm] [OUT.glb|.obj|.ply|.svg|.png]
# A classic L-system is derived (`grmc derive`); a file whose system has
# `mode = sample;` is grown guided by its curves (`grmc sample`, with
# EXAMPLE.curves.json beside it). EXAMPLE and OUT are relative to where
# it is run (default: the repository's examples/ternary_tree.grm, written
# to ternary_tree.glb and ternary_tree.png here).
set -euo pipefail
here="$(pwd)"
root="$(cd "$(dirname "$0")/.." && pwd)"
example="${1:-$root/examples/ternary_tree.grm}"
out="${2:-$(basename "${example%.grm}").glb}"
case "$example" in /*) ;; *) example="$here/$example" ;; esac
case "$out" in /*) ;; *) out="$here/$out" ;; esac
cd "$root"
cargo build --release -p grmc
# Where cargo put it (CARGO_TARGET_DIR, when set, moves the target folder).
grmc="${CARGO_TARGET_DIR:-$root/target}/release/grmc"
case "$grmc" in /*) ;; *) grmc="$root/$grmc" ;; esac
"$grmc" check examples/*.grm
outputs=("$out")
if [ $# -lt 2 ]; then outputs+=("${out%.*}.png"); fi
for o in "${outputs[@]}"; do
    if grep -Eq '^[[:space:]]*mode[[:space:]]*=[[:space:]]*sample[[:space:]]*;' "$example"; then
        "$grmc" sample "$example" -o "$o"
    else
        "$grmc" derive "$example" --stats -o "$o"
    fi
done
