#!/usr/bin/env bash
# Install a real VS Code for the editor test: code-server 4.100.3 (VS Code
# 1.100.3, the last line whose engines.node is 20) from the npm registry
# alone, with no download from GitHub or nodejs.org:
#   - `npm install --ignore-scripts code-server@4.100.3` (its postinstall
#     would fetch prebuilt binaries), then by hand what the postinstall does:
#   - the native modules compiled with npm's own node-gyp against the headers
#     of the node that runs them (argon2; in lib/vscode node-pty,
#     @vscode/spdlog, native-watchdog, @vscode/deviceid, kerberos);
#   - lib/vscode's production dependencies with --ignore-scripts, and
#     Debian's ripgrep where @vscode/ripgrep expects its binary.
# Debian packages it needs (ripgrep, libkrb5-dev, build-essential, python3)
# are installed when missing (as root, CI's fresh machine).
#
# The install is cached, keyed by the version, the node ABI, the
# architecture and this script's hash: a second run prints the folder and
# returns at once. It is built in a temporary folder beside it and moved
# into place only when complete, under a lock (runs at the same time wait
# for each other). A failed step prints the end of its log.
#
#   scripts/code-server-setup.sh          # prints the install folder (last line of stdout)
# Environment: GRM_CODE_SERVER_CACHE     the parent of the install folders
#                                        (default ${XDG_CACHE_HOME:-~/.cache}/grm)
# Run it: node DIR/node_modules/code-server/out/node/entry.js --help
set -euo pipefail

version=4.100.3
node_bin="$(command -v node || true)"
if [ -z "$node_bin" ]; then echo "code-server-setup: node (20) is needed" >&2; exit 1; fi
node_major="$(node -p 'process.versions.node.split(".")[0]')"
if [ "$node_major" != 20 ]; then
    echo "code-server-setup: code-server $version needs node 20 (this is $(node --version))" >&2
    exit 1
fi
abi="$(node -p process.versions.modules)"
arch="$(node -p process.arch)"
cache="${GRM_CODE_SERVER_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/grm}"
# This script's own hash: a changed recipe installs afresh (older folders stay
# until deleted by hand).
recipe="$(sha256sum "${BASH_SOURCE[0]}" | cut -c1-10)"
name="code-server-$version-node$abi-$arch-$recipe"
dir="$cache/$name"
entry="$dir/node_modules/code-server/out/node/entry.js"

if [ -f "$dir/.complete" ] && [ -f "$entry" ]; then
    echo "$dir"
    exit 0
fi

mkdir -p "$cache"
exec 9>"$cache/.code-server-$version.lock"
if ! flock -w 1800 9; then echo "code-server-setup: another install holds $cache/.code-server-$version.lock" >&2; exit 1; fi
# Installed by another run while this one waited.
if [ -f "$dir/.complete" ] && [ -f "$entry" ]; then
    echo "$dir"
    exit 0
fi

start=$SECONDS
log() { echo "code-server-setup: [$((SECONDS - start)) s] $*" >&2; }
# The build's output goes to a log, shown (its end) only when a step fails.
setup_log="$cache/$name.log"
: > "$setup_log"
trap 'echo "code-server-setup: failed; the end of $setup_log:" >&2; tail -n 40 "$setup_log" >&2' ERR

# Debian packages: rg for the search, krb5 headers for kerberos, a C++
# toolchain and python3 for node-gyp.
missing=()
if command -v dpkg-query >/dev/null 2>&1; then
    for p in ripgrep libkrb5-dev build-essential python3; do
        dpkg-query -W -f='${Status}\n' "$p" 2>/dev/null | grep -q '^install ok installed$' || missing+=("$p")
    done
else
    command -v rg >/dev/null 2>&1 || missing+=(ripgrep)
    [ -f /usr/include/krb5.h ] || missing+=(libkrb5-dev)
    command -v g++ >/dev/null 2>&1 && command -v make >/dev/null 2>&1 || missing+=(build-essential)
    command -v python3 >/dev/null 2>&1 || missing+=(python3)
fi
if [ ${#missing[@]} -gt 0 ]; then
    log "installing ${missing[*]}"
    if [ "$(id -u)" != 0 ]; then echo "code-server-setup: needs the Debian packages ${missing[*]} (run as root, or install them)" >&2; exit 1; fi
    apt-get update >>"$setup_log" 2>&1
    DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "${missing[@]}" >>"$setup_log" 2>&1
fi

# npm's own node-gyp, and the headers of this node (no header download).
npm_cli="$(readlink -f "$(command -v npm)")"
ng="$(dirname "$npm_cli")/../node_modules/node-gyp/bin/node-gyp.js"
if [ ! -f "$ng" ]; then echo "code-server-setup: npm's node-gyp is not at $ng" >&2; exit 1; fi
ng="$(readlink -f "$ng")"
nodedir="$(dirname "$(dirname "$(readlink -f "$node_bin")")")"
if [ ! -f "$nodedir/include/node/node.h" ]; then
    echo "code-server-setup: the node headers are not in $nodedir/include/node (node-gyp would download them)" >&2
    exit 1
fi
export npm_config_nodedir="$nodedir"
jobs="$(nproc 2>/dev/null || echo 2)"
npm_quiet=(--no-audit --no-fund --loglevel=error)

tmp="$cache/.$name.tmp"
rm -rf "$tmp" "$dir"
mkdir -p "$tmp"
cd "$tmp"
printf '{ "name": "grm-code-server", "private": true }\n' > package.json

log "npm install code-server@$version (no install scripts)"
npm install --ignore-scripts "${npm_quiet[@]}" "code-server@$version" >>"$setup_log" 2>&1
cs="$tmp/node_modules/code-server"

log "building argon2"
(cd "$tmp/node_modules/argon2" && PATH="$(dirname "$ng"):$PATH" ../@mapbox/node-pre-gyp/bin/node-pre-gyp rebuild --build-from-source --nodedir="$nodedir" -j "$jobs") >>"$setup_log" 2>&1

log "lib/vscode: production dependencies (no install scripts)"
cd "$cs/lib/vscode"
npm install --omit=dev --ignore-scripts "${npm_quiet[@]}" >>"$setup_log" 2>&1
mkdir -p node_modules/@vscode/ripgrep/bin
ln -sf "$(command -v rg)" node_modules/@vscode/ripgrep/bin/rg

for m in node-pty @vscode/spdlog native-watchdog @vscode/deviceid kerberos; do
    log "building $m"
    (cd "node_modules/$m" && node "$ng" rebuild --nodedir="$nodedir" -j "$jobs") >>"$setup_log" 2>&1
done
# @parcel/watcher needs no build: npm installed @parcel/watcher-linux-x64-glibc.

# The rest of code-server's postinstall.
ln -sfn node_modules node_modules.asar
(cd bin/remote-cli && ln -sf code-linux.sh code-server)
(cd bin/helpers && ln -sf browser-linux.sh browser.sh)
log "lib/vscode/extensions: dependencies of the built-in extensions"
# Its own postinstall only trims typescript.
(cd extensions && npm install --omit=dev "${npm_quiet[@]}") >>"$setup_log" 2>&1

# Every native module loads in this node.
cd "$cs/lib/vscode"
node -e '
for (const m of ["node-pty", "@vscode/spdlog", "native-watchdog", "@vscode/deviceid", "kerberos"]) require(m);
require(process.argv[1]);
' "$tmp/node_modules/argon2"
# (--config: it writes a default config file where none is.)
node "$tmp/node_modules/code-server/out/node/entry.js" --config "$tmp/version-check.yaml" --version >>"$setup_log" 2>&1
rm -f "$tmp/version-check.yaml"

cd "$cache"
touch "$tmp/.complete"
mv "$tmp" "$dir"
log "installed in $dir"
echo "$dir"
