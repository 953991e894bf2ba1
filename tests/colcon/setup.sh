#!/usr/bin/env bash
# Install colcon (colcon-common-extensions from PyPI, pinned in tests/colcon/requirements.txt) into a venv of
# its own, for the colcon workspace test (tests/ros/test_colcon.py). It stays apart from the ROS peer's venv
# (tests/peer/setup.sh), which other clones share: as on a Jazzy machine, colcon is one tool and ament, rosidl
# and rclpy (the peer) another, and colcon runs cmake in whatever ROS environment is sourced.
#
# Usage:  tests/colcon/setup.sh          prints the colcon executable to use last
#
#   GRASP_ORIENT_COLCON_CACHE  folder for colcon-<hash>/ (default: ${XDG_CACHE_HOME:-~/.cache}/grasp_orient)
#   GRASP_ORIENT_PEER_PYTHON   CPython 3.11 to build the venv from (default: python3.11 on PATH, else python3 if
#                              it is 3.11). 3.11 like the peer: colcon names the PYTHONPATH of the workspace's
#                              install after its own interpreter (lib/python3.11/site-packages), and the peer's
#                              Python 3.11 is what installs the grasp_orient message module there.
#
# Idempotent and cached: one venv per content of requirements.txt and base Python, in colcon-<hash>/, so
# branches with other pins do not reinstall each other's. Locked (flock) against parallel runs.
# Needs: CPython 3.11 with venv (tests/peer/setup.sh installs it with apt-get where missing), network access
# to PyPI on the first run.
set -euo pipefail

# log (on stderr), die, the ERR trap, setup_lock, run_logged
# shellcheck source=SCRIPTDIR/../setup-lib.sh
source "$(dirname "${BASH_SOURCE[0]}")/../setup-lib.sh"
setup_init colcon-setup stderr

SCRIPT_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
REQUIREMENTS="$SCRIPT_DIR/requirements.txt"
[ -f "$REQUIREMENTS" ] || die "missing $REQUIREMENTS"
CACHE="${GRASP_ORIENT_COLCON_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/grasp_orient}"

py_is_311() { "$1" -c 'import sys; sys.exit(0 if sys.version_info[:2] == (3, 11) else 1)' >/dev/null 2>&1; }
if [ -n "${GRASP_ORIENT_PEER_PYTHON:-}" ]; then
    py_is_311 "$GRASP_ORIENT_PEER_PYTHON" \
        || die "GRASP_ORIENT_PEER_PYTHON=$GRASP_ORIENT_PEER_PYTHON is not a working CPython 3.11"
    BASE_PY="$GRASP_ORIENT_PEER_PYTHON"
else
    BASE_PY=""
    for c in python3.11 python3 /usr/bin/python3.11; do
        if command -v "$c" >/dev/null 2>&1 && py_is_311 "$c"; then BASE_PY="$(command -v "$c")"; break; fi
    done
    [ -n "$BASE_PY" ] || die "no CPython 3.11 found (run tests/peer/setup.sh first: it installs python3.11 with apt-get)"
fi
BASE_PY="$("$BASE_PY" -c 'import os, sys; print(os.path.realpath(sys.executable))')"
"$BASE_PY" -c 'import venv, ensurepip' >/dev/null 2>&1 \
    || die "$BASE_PY cannot create venvs (Debian: apt-get install python3.11-venv)"

HASH="$( { cat "$REQUIREMENTS"; echo "python=$BASE_PY $("$BASE_PY" -c 'import sys; print(sys.version)')"; } \
    | sha256sum | cut -d' ' -f1)"
DIR="$CACHE/colcon-${HASH:0:16}"
VENV="$DIR/venv"
STAMP="$VENV/.grasp_orient_colcon.sha256"
COLCON="$VENV/bin/colcon"
mkdir -p "$DIR"

# One setup at a time per colcon-<hash>/ (parallel CI jobs sharing the cache).
setup_lock "$DIR/.lock"
setup_logs "$DIR" 40   # run_logged NAME CMD...: output in $DIR/NAME.log, its last 40 lines on stderr on failure

if [ -x "$COLCON" ] && [ -f "$STAMP" ] && [ "$(cat "$STAMP")" = "$HASH" ]; then
    log "colcon up to date: $VENV"
else
    log "creating $VENV from $BASE_PY and installing tests/colcon/requirements.txt"
    rm -rf "$VENV"
    run_logged venv "$BASE_PY" -m venv "$VENV"
    # The environment's pip configuration (index, certificates) applies; never use a user site.
    run_logged pip-install env -u PYTHONPATH PYTHONNOUSERSITE=1 "$VENV/bin/python" -m pip install \
        --no-input --progress-bar off --disable-pip-version-check -r "$REQUIREMENTS"
    run_logged pip-check "$VENV/bin/python" -m pip check
    # colcon must find ament_cmake packages (colcon-ros) and build CMake ones (colcon-cmake)
    run_logged import-check env -u PYTHONPATH "$VENV/bin/python" -c 'import colcon_core, colcon_cmake, colcon_ros, catkin_pkg'
    run_logged colcon-help env -u PYTHONPATH "$COLCON" build --help
    echo "$HASH" >"$STAMP"
fi

log "ready; use: $COLCON"
echo "$COLCON"
