#!/usr/bin/env bash
# Install what the Python module's tests need (maturin, numpy, pytest from PyPI, pinned in
# tests/python/requirements.txt) into a venv of its own, and build the module from this repository
# into it (`maturin develop`, crates/python), for tests/python/ and benches/bench_python.py.
#
# Usage:  tests/python/setup.sh [--release]    prints the venv's python to use last
#
#   --release                  build the module in the release profile (the benchmark); default: the
#                              test profile, which reuses what `cargo test` compiled of the workspace
#   GRASP_ORIENT_PYTHON_CACHE  folder for python-<hash>/ (default: ${XDG_CACHE_HOME:-~/.cache}/grasp_orient)
#   GRASP_ORIENT_PYTHON        CPython >= 3.9 to build the venv from (default: python3 on PATH)
#
# The venv is cached, one per content of requirements.txt and base Python, in python-<hash>/, and locked
# (flock) against parallel runs. The module is built every time (cargo decides what is fresh), so the
# venv always holds the module of this clone.
# Needs: CPython >= 3.9 with venv, cargo, network access to PyPI on the first run.
set -euo pipefail

# log (on stderr), die, the ERR trap, setup_lock, run_logged
# shellcheck source=SCRIPTDIR/../setup-lib.sh
source "$(dirname "${BASH_SOURCE[0]}")/../setup-lib.sh"
setup_init python-setup stderr

PROFILE=test
case "${1:-}" in
    "") ;;
    --release) PROFILE=release ;;
    *) die "unknown argument ${1} (usage: tests/python/setup.sh [--release])" ;;
esac

SCRIPT_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
REPO="$(cd "$SCRIPT_DIR/../.." && pwd)"
REQUIREMENTS="$SCRIPT_DIR/requirements.txt"
[ -f "$REQUIREMENTS" ] || die "missing $REQUIREMENTS"
CACHE="${GRASP_ORIENT_PYTHON_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/grasp_orient}"

BASE_PY="${GRASP_ORIENT_PYTHON:-$(command -v python3 || true)}"
[ -n "$BASE_PY" ] || die "no python3 on PATH (set GRASP_ORIENT_PYTHON to a CPython >= 3.9)"
"$BASE_PY" -c 'import sys; sys.exit(0 if sys.version_info[:2] >= (3, 9) else 1)' >/dev/null 2>&1 \
    || die "$BASE_PY is not a working CPython >= 3.9"
BASE_PY="$("$BASE_PY" -c 'import os, sys; print(os.path.realpath(sys.executable))')"
"$BASE_PY" -c 'import venv, ensurepip' >/dev/null 2>&1 \
    || die "$BASE_PY cannot create venvs (Debian: apt-get install python3-venv)"

HASH="$( { cat "$REQUIREMENTS"; echo "python=$BASE_PY $("$BASE_PY" -c 'import sys; print(sys.version)')"; } \
    | sha256sum | cut -d' ' -f1)"
DIR="$CACHE/python-${HASH:0:16}"
VENV="$DIR/venv"
STAMP="$VENV/.grasp_orient_python.sha256"
mkdir -p "$DIR"

setup_lock "$DIR/.lock"
setup_logs "$DIR" 60

if [ -x "$VENV/bin/maturin" ] && [ -f "$STAMP" ] && [ "$(cat "$STAMP")" = "$HASH" ]; then
    log "venv up to date: $VENV"
else
    log "creating $VENV from $BASE_PY and installing tests/python/requirements.txt"
    rm -rf "$VENV"
    run_logged venv "$BASE_PY" -m venv "$VENV"
    # The environment's pip configuration (index, certificates) applies; never use a user site.
    run_logged pip-install env -u PYTHONPATH PYTHONNOUSERSITE=1 "$VENV/bin/python" -m pip install \
        --no-input --progress-bar off --disable-pip-version-check -r "$REQUIREMENTS"
    run_logged pip-check "$VENV/bin/python" -m pip check
    echo "$HASH" >"$STAMP"
fi

# The module: crates/python built by cargo in the workspace's target folder, then installed into the
# venv. The test profile (the default) is the one `cargo test` builds the root crate and every
# dependency in (opt-level 2), so only PyO3, numpy's bindings and crates/python itself compile here;
# `maturin develop --profile test` cannot be used for it, since maturin builds through `cargo rustc`,
# which with that profile compiles a test harness instead of the module. The test build is installed
# as maturin develop installs a mixed project: the package's Python files and the native library,
# named as CPython's abi3 loader finds it. --release builds and installs the wheel with maturin (an
# editable install: the library beside the package's Python files, a .pth naming their folder;
# numpy, which the package requires, is installed already).
START=$SECONDS
SITE="$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
if [ "$PROFILE" = release ]; then
    log "building crates/python with maturin develop --release into $VENV"
    rm -rf "$SITE/grasp_orient"
    run_logged maturin-develop env -u PYTHONPATH VIRTUAL_ENV="$VENV" PATH="$VENV/bin:$PATH" \
        PYO3_PYTHON="$VENV/bin/python" "$VENV/bin/maturin" develop --release \
        --manifest-path "$REPO/crates/python/Cargo.toml"
else
    log "building crates/python (test profile) into $VENV"
    # The workspace's other crates are selected too, as `cargo test` selects them: built as
    # dependencies of the module alone, cargo compiled them once more (147 s on the 2-core machine
    # after `cargo test --all-targets --no-run`; selected, nothing but the module's own crates).
    run_logged cargo-build env PYO3_PYTHON="$VENV/bin/python" cargo build --profile test \
        --manifest-path "$REPO/Cargo.toml" -p grasp_orient_python -p grasp_orient \
        -p grasp_orient_solver -p grasp_orient_geometry --features pyo3/extension-module
    TARGET="${CARGO_TARGET_DIR:-$REPO/target}"
    # maturin's editable install of another build leaves a .pth that would shadow this copy.
    rm -f "$SITE"/grasp_orient*.pth
    rm -rf "$SITE/grasp_orient" "$SITE"/grasp_orient-*.dist-info
    cp -r "$REPO/crates/python/python/grasp_orient" "$SITE/grasp_orient"
    rm -f "$SITE/grasp_orient"/*.so
    cp "$TARGET/debug/lib_grasp_orient.so" "$SITE/grasp_orient/_grasp_orient.abi3.so"
fi
run_logged import-check env -u PYTHONPATH "$VENV/bin/python" -c 'import grasp_orient; grasp_orient.solve'
log "module built and installed in $((SECONDS - START)) s"

log "ready; use: $VENV/bin/python"
echo "$VENV/bin/python"
