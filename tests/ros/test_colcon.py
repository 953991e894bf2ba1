"""The repository as a ROS 2 Jazzy user builds it: copied into a colcon workspace's `src/`, `colcon build`,
`source install/setup.bash`; then the installed node answers rclpy, which uses the installed messages.

The build runs on the ROS peer's venv as the underlay (ament_cmake, rosidl, rclpy: what /opt/ros/jazzy is on
a ROS machine), without the peer's own build of grasp_orient's messages, so that everything grasp_orient
comes from the workspace. Run by tests/run.sh; on its own:

    source "$(bash tests/peer/setup.sh | tail -n1)"
    export GRASP_ORIENT_COLCON="$(bash tests/colcon/setup.sh | tail -n1)"
    cargo build --profile test && python -m pytest tests/ros/test_colcon.py -v

Environment:
    GRASP_ORIENT_COLCON          the colcon executable (required; tests/colcon/setup.sh prints it)
    GRASP_ORIENT_COLCON_RELEASE  1: build as a user's plain `colcon build` does (release, cargo's target in
                                 the workspace's build/: a full compile, 11.5 min measured on 2 busy cores).
                                 Default: `--cmake-args -DGRASP_ORIENT_CARGO_PROFILE=test
                                 -DGRASP_ORIENT_CARGO_TARGET_DIR=T`, T the clone's cargo target
                                 (${CARGO_TARGET_DIR:-<repo>/target}). `cargo test` has built every
                                 dependency there in the test profile, so little compiles (a dev build
                                 would recompile every dependency: cargo keys them by profile).
                                 Cargo.toml gives the node's dependencies the features the
                                 dev-dependencies turn on; tests/run.sh keeps clippy-driver as
                                 RUSTC_WORKSPACE_WRAPPER, which the workspace's crates are keyed by.

A missing colcon, a missing peer or a failed build fails every test here; nothing skips.
"""
from __future__ import annotations

import ast
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import (
    DOMAIN_ID, PAPER_CASES, REPO_ROOT, _ALL_NODES, NodeProcess, compare, load_paper_cases, ros_env, run_python, run_solve,
)

ASK_INSTALLED = REPO_ROOT / "tests" / "colcon" / "ask_installed.py"
BUILD_TIMEOUT_S = 1800.0  # a release build from scratch on 2 busy cores stays well under this
PATH_LISTS = ("PYTHONPATH", "LD_LIBRARY_PATH", "AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH")
PACKAGE_FILES = ("package.xml", "launch/grasp_orient.launch.py", "config/grasp_orient.yaml")


def underlay_env() -> dict:
    """The sourced peer environment less the peer's own grasp_orient install (and any other workspace)."""
    peer_dir = os.environ.get("GRASP_ORIENT_PEER_DIR")
    if not peer_dir:
        pytest.fail("the ROS peer environment is not sourced: "
                    "source \"$(bash tests/peer/setup.sh | tail -n1)\" first", pytrace=False)
    peer_installs = os.path.join(os.path.realpath(peer_dir), "install-")
    env = dict(os.environ)
    for var in PATH_LISTS:
        kept = [p for p in env.get(var, "").split(os.pathsep)
                if p and not os.path.realpath(p).startswith(peer_installs)]
        if kept:
            env[var] = os.pathsep.join(kept)
        else:
            env.pop(var, None)
    for var in ("COLCON_PREFIX_PATH", "GRASP_ORIENT_RCL_PEER"):
        env.pop(var, None)
    return env


def copy_sources(dest: Path):
    """The repository's tracked and untracked-but-not-ignored files, as a clone would hold them, with their
    modification times (so cargo, sharing the clone's target folder, sees nothing new)."""
    r = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=REPO_ROOT,
                       capture_output=True, timeout=60)
    if r.returncode != 0:
        pytest.fail(f"git ls-files failed in {REPO_ROOT}: {r.stderr.decode(errors='replace')}", pytrace=False)
    for rel in sorted({p for p in r.stdout.decode().split("\0") if p}):
        src = REPO_ROOT / rel
        if not os.path.lexists(src):  # tracked but deleted in the work tree
            continue
        (dest / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, dest / rel, follow_symlinks=False)


def sourced_env(setup_bash: Path, base: dict) -> dict:
    """The environment after `source SETUP_BASH` in bash, on top of `base`."""
    r = subprocess.run(["bash", "-c", 'source "$1" && env -0', "bash", str(setup_bash)], env=base,
                       capture_output=True, timeout=60)
    assert r.returncode == 0, f"source {setup_bash} failed ({r.returncode}): {r.stderr.decode(errors='replace')}"
    return dict(item.split("=", 1) for item in r.stdout.decode().split("\0") if "=" in item)


def under(path: str | Path, root: Path) -> bool:
    return Path(os.path.realpath(path)).is_relative_to(root.resolve())


class Workspace:
    def __init__(self, root: Path, base_env: dict, cmake_args: list[str]):
        self.root = root
        self.src = root / "src" / "grasp_orient"
        self.install = root / "install"
        self.prefix = self.install / "grasp_orient"
        self.share = self.prefix / "share" / "grasp_orient"
        self.node_bin = self.prefix / "lib" / "grasp_orient" / "grasp_orient"
        self.base_env = base_env
        self.cmake_args = cmake_args
        self.log = root / "colcon_build.log"
        self.env: dict = {}


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Workspace:
    """A colcon workspace with this repository in src/, built with `colcon build`, and the environment of
    its `install/setup.bash`."""
    colcon = os.environ.get("GRASP_ORIENT_COLCON")
    if not colcon or not os.access(colcon, os.X_OK):
        pytest.fail(f"GRASP_ORIENT_COLCON={colcon!r} is not an executable colcon: "
                    "export GRASP_ORIENT_COLCON=\"$(bash tests/colcon/setup.sh | tail -n1)\"", pytrace=False)
    if os.environ.get("GRASP_ORIENT_COLCON_RELEASE") == "1":
        cmake_args = []
    else:
        target = Path(os.environ.get("CARGO_TARGET_DIR") or REPO_ROOT / "target").resolve()
        cmake_args = ["--cmake-args", "-DGRASP_ORIENT_CARGO_PROFILE=test", f"-DGRASP_ORIENT_CARGO_TARGET_DIR={target}"]
    ws = Workspace(tmp_path_factory.mktemp("colcon_ws"), underlay_env(), cmake_args)
    copy_sources(ws.src)
    cmd = [colcon, "build", "--event-handlers", "console_direct+", *cmake_args]
    with open(ws.log, "w") as log:
        log.write(f"$ {' '.join(cmd)}   (in {ws.root})\n")
        log.flush()
        try:
            r = subprocess.run(cmd, cwd=ws.root, env=ws.base_env, stdin=subprocess.DEVNULL, stdout=log,
                               stderr=subprocess.STDOUT, timeout=BUILD_TIMEOUT_S)
            rc = r.returncode
        except subprocess.TimeoutExpired:
            rc = f"timeout after {BUILD_TIMEOUT_S:.0f} s"
    if rc != 0:
        tail = "\n".join(ws.log.read_text(errors="replace").splitlines()[-80:])
        pytest.fail(f"`colcon build` failed ({rc}); last lines of {ws.log}:\n{tail}", pytrace=False)
    ws.env = sourced_env(ws.install / "setup.bash", ws.base_env)
    return ws


def test_colcon_build_installs_node_launch_and_params(workspace):
    ws = workspace
    assert "Summary: 1 package finished" in ws.log.read_text(errors="replace"), f"see {ws.log}"
    assert ws.node_bin.is_file() and os.access(ws.node_bin, os.X_OK), f"no executable {ws.node_bin}"
    for rel in PACKAGE_FILES:
        installed = ws.share / rel
        assert installed.is_file(), f"{rel} not installed in {ws.share}"
        assert installed.read_bytes() == (REPO_ROOT / rel).read_bytes(), f"{installed} differs from the repository's"
    # what `ros2 run` and launch look the package up by
    assert (ws.prefix / "share" / "ament_index" / "resource_index" / "packages" / "grasp_orient").is_file()


def test_launch_file_starts_the_installed_executable(workspace):
    """The launch and launch_ros wheels are not on PyPI, so the launch file cannot be run here: check that it
    compiles and that its Node action names the executable `ros2 launch` would start, lib/grasp_orient/grasp_orient."""
    path = workspace.share / "launch" / "grasp_orient.launch.py"
    tree = ast.parse(path.read_text(), str(path))
    compile(tree, str(path), "exec")
    assert any(isinstance(f, ast.FunctionDef) and f.name == "generate_launch_description" for f in tree.body)
    nodes = [n for n in ast.walk(tree)
             if isinstance(n, ast.Call) and getattr(n.func, "id", getattr(n.func, "attr", None)) == "Node"]
    assert len(nodes) == 1, f"expected one Node action in {path}"
    kw = {k.arg: k.value.value for k in nodes[0].keywords if isinstance(k.value, ast.Constant)}
    exe = workspace.prefix / "lib" / kw.get("package", "?") / kw.get("executable", "?")
    assert exe == workspace.node_bin, f"the launch file starts {kw}, not {workspace.node_bin}"


def test_setup_bash_puts_the_workspace_first(workspace):
    """After `source install/setup.bash`, ament's index (what ros2 run, launch and the launch file's params
    default use) finds grasp_orient in the workspace."""
    ws = workspace
    first = ws.env.get("AMENT_PREFIX_PATH", "").split(os.pathsep)[0]
    assert first and os.path.samefile(first, ws.prefix), ws.env.get("AMENT_PREFIX_PATH")
    code = ("from ament_index_python.packages import get_package_prefix, get_package_share_directory as s; "
            "print(get_package_prefix('grasp_orient')); print(s('grasp_orient'))")
    r = subprocess.run([sys.executable, "-c", code], env=ws.env, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    prefix, share = r.stdout.split()
    assert os.path.samefile(prefix, ws.prefix) and os.path.samefile(share, ws.share), r.stdout


def test_installed_node_answers_rclpy_using_the_installed_messages(workspace, tmp_path):
    ws = workspace
    env = ros_env(DOMAIN_ID, ws.env)
    # In a namespace of its own: the session's default node may be serving the plain topics.
    node = NodeProcess(["--ros-args", "-r", "__ns:=/colcon", "--params-file",
                        str(ws.share / "config" / "grasp_orient.yaml")], env,
                       tmp_path, name="installed grasp_orient node (colcon workspace)", binary=ws.node_bin)
    _ALL_NODES.append(node)
    node.wait_ready()
    try:
        r = run_python([str(ASK_INSTALLED), str(PAPER_CASES), "--ns", "/colcon"], env, timeout=120)
        assert r.returncode == 0, f"ask_installed.py exited {r.returncode}:\n{r.stderr[-3000:]}"
        got = json.loads(r.stdout.strip().splitlines()[-1])
    finally:
        node.stop_and_check()
    assert under(got["msg_module"], ws.install), \
        f"rclpy used grasp_orient.msg from {got['msg_module']}, not from {ws.install}"
    assert got["msg_libraries"], "no libgrasp_orient__* library loaded by rclpy"
    outside = [p for p in got["msg_libraries"] if not under(p, ws.install)]
    assert not outside, f"grasp_orient libraries loaded from outside the workspace: {outside}"
    cases = load_paper_cases()
    expected = run_solve(cases)
    diffs = [f"{c['id']}: {d}" for c, a, e in zip(cases, got["answers"], expected) for d in compare(a, e)]
    assert not diffs, "the installed node's answers differ from `solve`:\n" + "\n".join(diffs[:20])
    assert all(a["status"] == 0 for a in got["answers"]), [a["message"] for a in got["answers"]]


def test_plain_configure_is_a_release_build(workspace, tmp_path):
    """A user's plain `colcon build` (no build type) builds cargo's release profile into its own build
    folder, a Debug build the dev profile; the test's build took the profile it was given."""
    build = tmp_path / "build"

    def configure(*args: str) -> tuple[str, str]:
        r = subprocess.run(["cmake", "-S", str(workspace.src), "-B", str(build), "-DBUILD_TESTING=OFF", *args],
                           env=workspace.base_env, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, f"cmake configure {args} failed:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
        return ((build / "CMakeFiles" / "grasp_orient_node.dir" / "build.make").read_text(),
                (build / "cmake_install.cmake").read_text())

    make, install = configure()
    assert "--profile release --locked" in make and f"--target-dir {build}/cargo" in make, make
    assert f"{build}/cargo/release/grasp_orient" in install, install
    make, install = configure("-DCMAKE_BUILD_TYPE=Debug")
    assert "--profile dev --locked" in make, make
    assert f"{build}/cargo/debug/grasp_orient" in install, install
    built = (workspace.root / "build" / "grasp_orient" / "CMakeFiles" / "grasp_orient_node.dir"
             / "build.make").read_text()
    profile = "test" if workspace.cmake_args else "release"
    assert f"--profile {profile} --locked" in built, built
