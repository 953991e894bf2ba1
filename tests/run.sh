#!/usr/bin/env bash
# Runs every test of grasp_orient: formatting, lints, and the whole cargo test suite.
# This is the README's test command; .ci/run calls it.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== cargo fmt --check"
cargo fmt --check
echo "== cargo clippy --all-targets -- -D warnings"
cargo clippy --all-targets -- -D warnings
echo "== cargo test (clippy above already compiled the benches)"
cargo test
