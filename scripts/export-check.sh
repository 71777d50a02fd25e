#!/usr/bin/env bash
# Export checks: every shipped example grown into a .glb (the city's
# layout with its buildings too), and the shape
# builder's test houses (grm-geom's tests/shape.rs: windows with boxes and
# an OBJ each, and the same with an embedded PNG texture), each checked by
# the Khronos glTF validator (npm `gltf-validator`, tests/export/) and
# imported by Blender's own glTF importer (PyPI `bpy`, Blender as a Python
# module, in a virtual environment cached in ~/.cache/grm or
# GRM_BPY_CACHE). Installs what it needs from the registries; a failed
# install fails here, nothing is skipped.
#   ./scripts/export-check.sh [GRMC]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
grmc="${1:-}"
if [ -z "$grmc" ]; then
    cargo build --release -p grmc --locked
    grmc="${CARGO_TARGET_DIR:-$root/target}/release/grmc"
fi

(cd tests/export && npm ci --ignore-scripts --no-audit --no-fund >/dev/null)

# bpy 5.0 wheels are built for CPython 3.11.
cache="${GRM_BPY_CACHE:-$HOME/.cache/grm/bpy-5.0.1}"
py=python3.11
command -v "$py" >/dev/null 2>&1 || py=python3
if [ ! -x "$cache/bin/python" ] || ! "$cache/bin/python" -c "import bpy" >/dev/null 2>&1; then
    echo "== installing Blender's Python module (bpy 5.0.1) into $cache"
    rm -rf "$cache"
    "$py" -m venv "$cache"
    "$cache/bin/pip" install --quiet --disable-pip-version-check bpy==5.0.1
fi

out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
glbs=()
for ex in examples/*.grm; do
    name="$(basename "${ex%.grm}")"
    # common.grm is a library of declarations, not a system.
    grep -Eq '^[[:space:]]*system[[:space:]]' "$ex" || continue
    glb="$out/$name.glb"
    if grep -Eq '^[[:space:]]*mode[[:space:]]*=[[:space:]]*sample[[:space:]]*;' "$ex"; then
        "$grmc" sample "$ex" -o "$glb" >/dev/null
    else
        "$grmc" derive "$ex" -o "$glb" >/dev/null
    fi
    glbs+=("$glb")
done
# The example city (docs/layout.md): streets, parcels and a building on
# every parcel but the park, one node per street and parcel.
"$grmc" layout examples/city.layout.json -o "$out/city.glb" >/dev/null 2>&1
glbs+=("$out/city.glb")
mkdir "$out/houses"
GRM_SHAPE_GLB_OUT="$out/houses" cargo test -q --locked -p grm-geom --test shape sample_glbs_for_the_validator >/dev/null
node tests/export/validate.mjs "${glbs[@]}" "$out"/houses/*.glb
# Blender's importer logs a line per step: only the summary (or the
# failure) is shown; pipefail keeps the script's status.
blender() { "$cache/bin/python" tests/export/blender_import.py "$@" 2>&1 | grep '^blender_import'; }
for glb in "${glbs[@]}"; do
    case "$(basename "$glb")" in
        # Shape systems: one object per drawn shape, named by its semantic path.
        townhouse.glb) blender "$glb" 300 Glass.house1 Roof.house3 ;;
        office_tower.glb) blender "$glb" 2000 Glass.facade6 ;;
        facade_variety.glb) blender "$glb" 400 Glass.facade1.floor5 ;;
        # 225 streets, 196 parcels (with their buildings), open ground.
        city.glb) blender "$glb" 400 street. parcel. ;;
        *) blender "$glb" 1 ;;
    esac
done
for glb in "$out"/houses/*.glb; do
    # 40 groups: 3 side walls, the roof, 24 tile walls, 12 windows.
    blender "$glb" 40 Window.facade1 Roof.facade1
done
