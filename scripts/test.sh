#!/usr/bin/env bash
# Run every test of the grm workspace, as CI does. Installs what it needs.
#   ./scripts/test.sh
set -euo pipefail
cd "$(dirname "$0")/.."

# A clean CI build gains nothing from incremental caches, which would take
# about 2 GB of its disk.
if [ "${CI:-}" = true ]; then export CARGO_INCREMENTAL=0; fi

# Rust toolchain components used by the checks below.
if ! cargo fmt --version >/dev/null 2>&1; then rustup component add rustfmt; fi
if ! cargo clippy --version >/dev/null 2>&1; then rustup component add clippy; fi

echo "== cargo fmt --check"
cargo fmt --all -- --check

echo "== cargo clippy"
cargo clippy --workspace --all-targets --locked -- -D warnings

# GPU tests run on Mesa's software Vulkan driver (lavapipe) where there is
# no GPU; they fail (never skip) without an adapter.
if ! ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1; then
    echo "== installing Mesa's lavapipe (software Vulkan) for the GPU tests"
    apt-get update && apt-get install -y --no-install-recommends mesa-vulkan-drivers libvulkan1
fi

# Mesa's device-select layer would connect to a Wayland display and print
# "XDG_RUNTIME_DIR is invalid" for every GPU test on a headless machine
# (grmc itself switches it off there; the test binaries are not grmc).
if [ -z "${XDG_RUNTIME_DIR:-}" ]; then export NODEVICE_SELECT=1; fi

echo "== cargo test"
cargo test --workspace --locked

# Every example's .glb (and the shape builder's test houses) through the
# Khronos glTF validator and Blender's own importer (bpy from PyPI, cached
# in ~/.cache/grm by the script; a failed install fails here).
echo "== export checks: glTF validator and Blender"
if ! command -v python3.11 >/dev/null 2>&1 && ! python3 -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
    echo "Blender's Python module (bpy 5.0) needs CPython 3.11" >&2
    exit 1
fi
# The debug grmc (built for the CLI tests already): no release build here.
cargo build -p grmc --locked
bash scripts/export-check.sh "${CARGO_TARGET_DIR:-target}/debug/grmc"

# The VS Code extension and the preview page (editors/): node unit tests,
# then the page in headless Chromium against `grmc view` (Debian's chromium,
# no browser download; packages from the npm registry only).
echo "== editors: npm ci, build, unit tests, browser test"
if ! command -v node >/dev/null 2>&1; then
    echo "node (20 or later) is needed for the editors tests" >&2
    exit 1
fi
if [ ! -x /usr/bin/chromium ]; then
    apt-get update && apt-get install -y --no-install-recommends chromium
fi
(cd editors && npm ci --ignore-scripts --no-audit --no-fund)
(cd editors && node scripts/build.mjs && npm run --silent typecheck)
# grmc view embeds the committed page: it must be the build of the sources.
git diff --exit-code --stat -- editors/preview/dist
(cd editors && node --test out/test/)
bash editors/vscode/scripts/package.sh --out "${CARGO_TARGET_DIR:-target}/grm.vsix"
cargo build -p grmc --locked
(cd editors && node --test out/browser-test/)

# The extension in a real VS Code: code-server 4.100.3 (VS Code 1.100.3) from
# the npm registry alone, installed once and cached by scripts/code-server-setup.sh
# (in ~/.cache/grm, or GRM_CODE_SERVER_CACHE), driven by Playwright in
# Debian's chromium: highlighting, Problems, a hover, a quick fix, the preview
# and Export Model (editors/code-server-test/). A failed install fails here.
echo "== editors: the extension in code-server (a real VS Code)"
CODE_SERVER_DIR="$(bash scripts/code-server-setup.sh)"
export CODE_SERVER_DIR
node --test editors/code-server-test/
