#!/usr/bin/env bash
# Shape-mode export check: the glbs grm_geom::shape builds for its tests
# (a house with a facade of windows, boxes and an OBJ per window, and the
# same with an embedded PNG texture) through the Khronos glTF validator
# (npm `gltf-validator`, tests/export/), and, where Blender's Python module
# is cached (scripts/export-check.sh installs it), Blender's importer: one
# mesh object per terminal shape group, named by its semantic path, with
# its locators.
#   ./scripts/shape-export-check.sh
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
[ -d tests/export/node_modules/gltf-validator ] ||
    (cd tests/export && npm ci --ignore-scripts --no-audit --no-fund >/dev/null)
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
GRM_SHAPE_GLB_OUT="$out" cargo test -q -p grm-geom --test shape sample_glbs_for_the_validator >/dev/null
node tests/export/validate.mjs "$out"/*.glb
cache="${GRM_BPY_CACHE:-$HOME/.cache/grm/bpy-5.0.1}"
if [ -x "$cache/bin/python" ]; then
    for glb in "$out"/*.glb; do
        # 40 groups: 3 side walls, the roof, 24 tile walls, 12 windows.
        "$cache/bin/python" tests/export/blender_import.py "$glb" 40 Window.facade1 Roof.facade1 2>&1 |
            grep '^blender_import'
    done
else
    echo "shape-export-check: Blender's Python module is not cached in $cache (scripts/export-check.sh installs it); glTF validator only"
fi
