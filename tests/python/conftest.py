"""Shared by the Python module's tests: the module itself, and `grasp_orient solve` (the binary) to
hold every answer to.

A missing module or binary fails the run loudly (never a skip): the module is built into the venv
by tests/python/setup.sh, the binary by cargo (target/debug/grasp_orient, or GRASP_ORIENT_BIN).
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parent.parent.parent

try:
    import grasp_orient  # noqa: F401
except ImportError as e:  # pragma: no cover - the failure itself
    raise pytest.UsageError(
        f"the Python module grasp_orient is not installed in {os.sys.executable} ({e}); "
        "build it with: bash tests/python/setup.sh, and run pytest with the python it prints"
    ) from e


@pytest.fixture(scope="session")
def solve_bin() -> Path:
    path = Path(os.environ.get("GRASP_ORIENT_BIN", REPO_ROOT / "target" / "debug" / "grasp_orient"))
    if not path.is_file():
        pytest.fail(f"no grasp_orient binary at {path}: build it with cargo build (or cargo test --no-run), "
                    "or set GRASP_ORIENT_BIN", pytrace=False)
    return path
