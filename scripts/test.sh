#!/usr/bin/env bash
# Run every test of the grm workspace, as CI does. Installs what it needs.
#   ./scripts/test.sh
set -euo pipefail
cd "$(dirname "$0")/.."

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

echo "== cargo test"
cargo test --workspace --locked
