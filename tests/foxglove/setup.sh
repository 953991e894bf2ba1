#!/usr/bin/env bash
# Install Foxglove's own MCAP and ROS 2 decoders from npm, for tests/foxglove/decode.mjs: the packages
# pinned in tests/foxglove/package-lock.json (@mcap/core, @mcap/support's decompressors, @foxglove/rosmsg,
# @foxglove/rosmsg2-serialization), with Node.js and npm from Debian when they are missing.
#
# Usage:  tests/foxglove/setup.sh     prints, as its last line, the directory holding node_modules; then
#         GRASP_ORIENT_FOXGLOVE_DIR=<that dir> node tests/foxglove/decode.mjs BAG...
#
#   GRASP_ORIENT_FOXGLOVE_CACHE  where the installs live (default: ${XDG_CACHE_HOME:-~/.cache}/grasp_orient,
#                                outside the clone, so that fresh clones and CI runs on one machine share it)
#
# Idempotent and cached: one directory per content hash of package.json + package-lock.json
# (<cache>/foxglove-<hash>), installed once with `npm ci` into a temporary directory and renamed into place
# only when complete and checked. Needs: Node.js >= 18 and npm (Debian 12: apt-get install nodejs npm, done
# here when missing), network access to the npm registry (and to the Debian mirror when packages are missing).
# @foxglove/rosmsg2-serialization 3.1.0 declares node >= 20, so Debian 12's npm 9.2.0 warns EBADENGINE on
# Node.js 18.20.4; it installs and decode.mjs prints the same messages there as on Node.js 20 (checked).
set -euo pipefail

log() { printf '[foxglove-setup] %s\n' "$*" >&2; }
die() { printf '[foxglove-setup] ERROR: %s\n' "$*" >&2; exit 1; }
trap 'rc=$?; printf "[foxglove-setup] ERROR: command failed (exit %s) at %s line %s: %s\n" "$rc" "${BASH_SOURCE[0]}" "$LINENO" "$BASH_COMMAND" >&2' ERR

SCRIPT_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
CACHE="${GRASP_ORIENT_FOXGLOVE_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/grasp_orient}"
PACKAGES=(@mcap/core @mcap/support @foxglove/rosmsg @foxglove/rosmsg2-serialization)

for f in package.json package-lock.json decode.mjs; do
    [ -f "$SCRIPT_DIR/$f" ] || die "missing $SCRIPT_DIR/$f"
done
mkdir -p "$CACHE"
CACHE="$(cd "$CACHE" && pwd)"
LOGS="$CACHE/foxglove-logs"
mkdir -p "$LOGS"

# One setup at a time per cache (parallel CI jobs sharing it).
if command -v flock >/dev/null 2>&1; then
    exec 9>"$CACHE/.foxglove.lock"
    flock 9 || die "cannot lock $CACHE/.foxglove.lock"
fi

# run_logged NAME CMD...: run CMD with output in $LOGS/NAME.log; on failure show its tail on stderr.
run_logged() {
    local name="$1"; shift
    local logf="$LOGS/$name.log"
    if ! "$@" >"$logf" 2>&1; then
        printf '[foxglove-setup] ERROR: %s failed; last lines of %s:\n' "$name" "$logf" >&2
        tail -n 60 "$logf" >&2
        exit 1
    fi
}

# ---------------------------------------------------------------------------------------------------
# 1. Node.js and npm from Debian (only when missing)
# ---------------------------------------------------------------------------------------------------
APT_PKGS=()
command -v node >/dev/null 2>&1 || APT_PKGS+=(nodejs)
command -v npm >/dev/null 2>&1 || APT_PKGS+=(npm)
if [ "${#APT_PKGS[@]}" -gt 0 ]; then
    [ -f /etc/ssl/certs/ca-certificates.crt ] || APT_PKGS+=(ca-certificates)
    command -v apt-get >/dev/null 2>&1 \
        || die "missing ${APT_PKGS[*]} and no apt-get to install them (install Node.js >= 18 and npm)"
    SUDO=()
    if [ "$(id -u)" -ne 0 ]; then
        command -v sudo >/dev/null 2>&1 || die "need root (or sudo) to apt-get install ${APT_PKGS[*]}"
        SUDO=(sudo)
    fi
    log "apt-get install ${APT_PKGS[*]}"
    export DEBIAN_FRONTEND=noninteractive
    run_logged apt-get-update "${SUDO[@]}" apt-get update
    run_logged apt-get-install "${SUDO[@]}" apt-get install -y "${APT_PKGS[@]}"
fi
command -v node >/dev/null 2>&1 || die "'node' still missing after apt-get install nodejs"
command -v npm >/dev/null 2>&1 || die "'npm' still missing after apt-get install npm"
NODE_MAJOR="$(node -p 'process.versions.node.split(".")[0]')" || die "'node' does not run"
[ "$NODE_MAJOR" -ge 18 ] || die "Node.js $(node --version) is too old: decode.mjs and the pinned packages need >= 18 (Debian 12 has 18)"

# ---------------------------------------------------------------------------------------------------
# 2. npm ci into <cache>/foxglove-<hash> (cached by the content of package.json and the lock)
# ---------------------------------------------------------------------------------------------------
HASH="$(cat "$SCRIPT_DIR/package.json" "$SCRIPT_DIR/package-lock.json" | sha256sum | cut -c1-16)"
DIR="$CACHE/foxglove-$HASH"
STAMP="$DIR/.grasp_orient_complete"

# check DIR: every pinned package loads, and the lz4 and zstd decompressors of Foxglove's player start
check() {
    (cd "$1" && node -e '
        const handlers = require("@mcap/support").loadDecompressHandlers();
        for (const p of process.argv.slice(1)) require(p);
        handlers.then((h) => {
            for (const c of ["lz4", "zstd"]) if (typeof h[c] !== "function") throw new Error("no " + c + " decompressor");
        });' "${PACKAGES[@]}")
}

if [ -f "$STAMP" ] && check "$DIR" >"$LOGS/check.log" 2>&1; then
    log "up to date: $DIR"
else
    log "installing Foxglove's decoders with npm ci into $DIR (node $(node --version), npm $(npm --version))"
    TMP="$DIR.tmp.$$"
    rm -rf "$DIR".tmp.*   # left by an interrupted run (we hold the lock)
    trap 'rm -rf "$TMP"' EXIT
    mkdir -p "$TMP"
    cp "$SCRIPT_DIR/package.json" "$SCRIPT_DIR/package-lock.json" "$TMP/"
    # no install scripts: the pinned packages are JavaScript and WebAssembly, nothing to build
    run_logged npm-ci env -C "$TMP" npm ci --ignore-scripts --no-audit --no-fund --omit=dev
    run_logged check check "$TMP"
    date -u +%FT%TZ >"$TMP/.grasp_orient_complete"
    rm -rf "$DIR"
    mv "$TMP" "$DIR"
fi

cat >"$DIR/env.sh" <<EOF
# Generated by tests/foxglove/setup.sh: Foxglove's decoders for tests/foxglove/decode.mjs.
export GRASP_ORIENT_FOXGLOVE_DIR="$DIR"
EOF
log "ready: GRASP_ORIENT_FOXGLOVE_DIR=$DIR node tests/foxglove/decode.mjs BAG..."
echo "$DIR"
