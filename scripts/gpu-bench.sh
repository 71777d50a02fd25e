#!/usr/bin/env bash
# The GPU benchmark on a lent GPU machine (docs/benchmarks.md), which has
# no network: the benchmark is built here and carried there.
#
#   scripts/gpu-bench.sh prepare      # here: build and strip the benchmark
#                                     # into .gpu/, fetch the Vulkan loader
#                                     # into .gl/ (both git-excluded)
#   scripts/gpu-bench.sh run OUTDIR   # there, from the repository root, with
#                                     # .gpu and .gl carried: the scenes, one
#                                     # log per run in OUTDIR
#
# QUICK=1 runs every scene at 3 iterations and once (to try the script on
# a machine without a GPU, e.g. on lavapipe).
set -euo pipefail
cd "$(dirname "$0")/.."

case "${1:-}" in
prepare)
    cargo build --release --locked -p grm-gpu --example bench
    mkdir -p .gpu .gl /tmp/amd64/partial
    strip -o .gpu/bench target/release/examples/bench
    for p in /.gpu/ /.gl/; do
        grep -qxF "$p" .git/info/exclude 2>/dev/null || echo "$p" >>.git/info/exclude
    done
    o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
    # shellcheck disable=SC2086
    apt-get $o update -qq
    # shellcheck disable=SC2086
    (cd .gl && rm -f ./*.deb && apt-get $o download libvulkan1)
    du -sh .gpu .gl
    ;;
run)
    out=${2:?usage: scripts/gpu-bench.sh run OUTDIR}
    mkdir -p "$out"
    if ! ldconfig -p | grep -q libvulkan.so.1; then
        for f in .gl/*.deb; do dpkg -x "$f" /; done
        ldconfig
    fi
    icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
    if [ -z "${VK_DRIVER_FILES:-}" ] && [ -f "$icd" ]; then
        export VK_DRIVER_FILES=$icd
    fi
    b=.gpu/bench
    quick=()
    if [ "${QUICK:-}" = 1 ]; then quick=(-n 3 --runs 1); fi
    "$b" "${quick[@]}" >"$out/standard.txt" 2>&1 || echo "standard scenes failed" >>"$out/standard.txt"
    h7=(-n 7)
    if [ "${QUICK:-}" = 1 ]; then h7=(); fi
    "$b" --scene hilbert3d "${h7[@]}" "${quick[@]}" >"$out/hilbert7.txt" 2>&1 || true
    "$b" --scene hilbert3d "${h7[@]}" "${quick[@]}" --cpu-prefix 0 >"$out/hilbert7_gpu_only.txt" 2>&1 || true
    # Eight times Hilbert 7 (71 million modules, derived directly): the
    # rate once fixed costs are small beside the work.
    h8=(-n 8)
    if [ "${QUICK:-}" = 1 ]; then h8=(); fi
    "$b" --scene hilbert3d "${h8[@]}" "${quick[@]}" >"$out/hilbert8.txt" 2>&1 || true
    forest=(-n 7)
    if [ "${QUICK:-}" = 1 ]; then forest=(); fi
    "$b" --scene stochastic_plant "${forest[@]}" --forest 256 "${quick[@]}" >"$out/forest.txt" 2>&1 || true
    # A forest of deterministic trees (derived directly), and Hilbert 3D
    # at 5 for where the direct path starts to beat the CPU.
    tforest=(-n 8)
    h5=(-n 5)
    if [ "${QUICK:-}" = 1 ]; then tforest=(); h5=(); fi
    "$b" --scene ternary_tree "${tforest[@]}" --forest 64 "${quick[@]}" >"$out/forest_ternary.txt" 2>&1 || true
    "$b" --scene hilbert3d "${h5[@]}" "${quick[@]}" >"$out/hilbert5.txt" 2>&1 || true
    grep -h -E "^adapter|^scene|^forest|derive:|GPU derive|direct|stepwise|GPU only|interpret:|fused scan|total:|end to end|per timed run|CHECK|error" "$out"/*.txt
    # Each run's closing table against the 20,000 modules/us target.
    for f in "$out"/*.txt; do sed -n '/^summary:/,$p' "$f"; done
    ;;
*)
    sed -n '2,14p' "$0"
    exit 2
    ;;
esac
