#!/usr/bin/env bash
# Build the grm VS Code extension and package it as a .vsix.
#   editors/vscode/scripts/package.sh [--with-server PATH] [--out FILE]
# --with-server bundles a grmc binary (e.g. target/release/grmc) as
# server/grmc, the extension's second choice after the grm.server.path
# setting. Needs only the npm registry (npm ci) and node.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
editors="$(cd "$here/.." && pwd)"
server=""
out="$here/grm-$(node -p "require('$here/package.json').version").vsix"
while [ $# -gt 0 ]; do
    case "$1" in
        # Resolved now: the build below runs in another directory.
        --with-server) server="$(realpath -m "$2")"; shift 2 ;;
        --out) out="$(realpath -m "$2")"; shift 2 ;;
        *) echo "usage: $0 [--with-server PATH] [--out FILE]" >&2; exit 2 ;;
    esac
done

if [ -n "$server" ] && [ ! -f "$server" ]; then
    echo "error: --with-server $server: no such file (build it first: cargo build --release -p grmc)" >&2
    exit 2
fi

cd "$editors"
if [ ! -d node_modules ]; then npm ci --ignore-scripts --no-audit --no-fund; fi
node scripts/build.mjs

rm -rf "$here/server"
if [ -n "$server" ]; then
    mkdir -p "$here/server"
    cp "$server" "$here/server/grmc"
    chmod +x "$here/server/grmc"
fi

cd "$here"
mkdir -p "$(dirname "$out")"
# Everything is bundled by esbuild: the .vsix needs no node_modules.
"$editors/node_modules/.bin/vsce" package --no-dependencies --skip-license --allow-missing-repository --out "$out"
rm -rf "$here/server"
echo "packaged $out"
